//! Markdown tables.

/// A markdown table: a header row and data rows of equal width.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Table {
    pub header: Vec<String>,
    pub rows: Vec<Vec<String>>,
}

impl Table {
    pub fn new<S: Into<String>>(header: impl IntoIterator<Item = S>) -> Self {
        Table {
            header: header.into_iter().map(Into::into).collect(),
            rows: Vec::new(),
        }
    }

    /// Appends a row (padded or cut to the header's width).
    pub fn row<S: Into<String>>(&mut self, cells: impl IntoIterator<Item = S>) {
        let mut r: Vec<String> = cells.into_iter().map(Into::into).collect();
        r.resize(self.header.len(), String::new());
        self.rows.push(r);
    }

    /// GitHub-flavoured markdown; `|` in cells is escaped.
    pub fn to_markdown(&self) -> String {
        let esc = |s: &String| s.replace('|', "\\|");
        let mut out = String::new();
        let line = |cells: Vec<String>| format!("| {} |\n", cells.join(" | "));
        out += &line(self.header.iter().map(esc).collect());
        out += &line(self.header.iter().map(|_| "---".to_string()).collect());
        for r in &self.rows {
            out += &line(r.iter().map(esc).collect());
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn markdown_with_padding_and_escapes() {
        let mut t = Table::new(["a", "b"]);
        t.row(["1", "x|y"]);
        t.row(["2"]);
        assert_eq!(
            t.to_markdown(),
            "| a | b |\n| --- | --- |\n| 1 | x\\|y |\n| 2 |  |\n"
        );
    }
}
