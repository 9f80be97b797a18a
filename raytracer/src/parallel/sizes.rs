//! Sizes a parallel render is given per processor: the cache budget
//! ([`CacheSize`], `--cache`) and what one demand-driven task may fetch
//! ([`FetchLimit`], `--fetch-limit`).

use serde::Serialize;

/// A per-processor cache budget.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub enum CacheSize {
    Unlimited,
    Bytes(u64),
    /// Percent of the scene's total cell data.
    Percent(f64),
}

impl std::str::FromStr for CacheSize {
    type Err = String;
    /// `unlimited`, a byte count with an optional `K`/`M`/`G` suffix
    /// (powers of 1024), or a percentage like `10%`.
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        let t = s.trim();
        let bad = || {
            format!("cache size {s:?}: expected unlimited, a byte count like 64M, or a percentage like 10%")
        };
        if t.eq_ignore_ascii_case("unlimited") || t.eq_ignore_ascii_case("none") {
            return Ok(CacheSize::Unlimited);
        }
        if let Some(p) = t.strip_suffix('%') {
            let v: f64 = p.trim().parse().map_err(|_| bad())?;
            return if v.is_finite() && v >= 0.0 {
                Ok(CacheSize::Percent(v))
            } else {
                Err(bad())
            };
        }
        let (num, mult) = match t.chars().last().map(|c| c.to_ascii_uppercase()) {
            Some('K') => (&t[..t.len() - 1], 1u64 << 10),
            Some('M') => (&t[..t.len() - 1], 1 << 20),
            Some('G') => (&t[..t.len() - 1], 1 << 30),
            _ => (t, 1),
        };
        let v: u64 = num.trim().parse().map_err(|_| bad())?;
        v.checked_mul(mult).map(CacheSize::Bytes).ok_or_else(bad)
    }
}

impl CacheSize {
    /// The budget in bytes for a scene with `data_bytes` of cell data.
    pub fn resolve(self, data_bytes: u64) -> Option<u64> {
        match self {
            CacheSize::Unlimited => None,
            CacheSize::Bytes(b) => Some(b),
            CacheSize::Percent(p) => Some((data_bytes as f64 * p / 100.0).round() as u64),
        }
    }
}

/// Most cell data one demand-driven task may have fetched for it
/// ([`super::ParallelOptions::fetch_limit`], `--fetch-limit`; the framework's
/// [`hybrid_sched::Config::fetch_limit`]): a task with more to fetch
/// traces data-parallel. The picture is the same whatever the limit.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub enum FetchLimit {
    /// With a budgeted cache, the budget over [`FetchLimit::AUTO_SHARE`]
    /// and at least [`FetchLimit::AUTO_FLOOR`]; none with an unlimited
    /// cache (whose processors complete their cache instead). What
    /// `render` uses: on the 1.5M-triangle city at `-np 4 --cache 10%` it
    /// keeps every rank's peak at or under issue 19's bound, where the paper's
    /// unlimited fetches overshoot by up to 52 MiB (the book's MPI chapter).
    Auto,
    /// A fixed limit (`Unlimited`: the paper's scheduler).
    Size(CacheSize),
}

impl FetchLimit {
    /// [`FetchLimit::Auto`]'s share of the cache budget: one 32nd.
    pub const AUTO_SHARE: u64 = 32;
    /// [`FetchLimit::Auto`]'s least limit, 64 KiB: a small cache's budget
    /// over 32 would send nearly every task data-parallel (the studio at
    /// `--cache 10%`: 6.7 KiB; at 2 KiB its render took 1.4x as long).
    pub const AUTO_FLOOR: u64 = 64 << 10;

    /// The limit in bytes for a scene with `data_bytes` of cell data and a
    /// cache of `cache_bytes` (`None`: unlimited) per processor.
    pub fn resolve(self, data_bytes: u64, cache_bytes: Option<u64>) -> Option<u64> {
        match self {
            FetchLimit::Auto => cache_bytes.map(|c| (c / Self::AUTO_SHARE).max(Self::AUTO_FLOOR)),
            FetchLimit::Size(s) => s.resolve(data_bytes),
        }
    }
}

impl std::str::FromStr for FetchLimit {
    type Err = String;
    /// `auto`, or what [`CacheSize`] reads.
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        if s.trim().eq_ignore_ascii_case("auto") {
            return Ok(FetchLimit::Auto);
        }
        s.parse()
            .map(FetchLimit::Size)
            .map_err(|_| format!("fetch limit {s:?}: expected auto, unlimited, a byte count like 1M, or a percentage like 1%"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn auto_takes_a_share_of_a_budgeted_cache_and_none_of_an_unlimited_one() {
        let auto: FetchLimit = "auto".parse().unwrap();
        assert_eq!(auto, FetchLimit::Auto);
        assert_eq!(auto.resolve(1 << 30, None), None);
        assert_eq!(auto.resolve(1 << 30, Some(32 << 20)), Some(1 << 20));
        // The floor, also above a budget smaller than itself.
        assert_eq!(auto.resolve(1 << 30, Some(213 << 10)), Some(64 << 10));
        assert_eq!(auto.resolve(1 << 30, Some(0)), Some(64 << 10));
    }

    #[test]
    fn fixed_limits_read_as_cache_sizes() {
        let l: FetchLimit = "1M".parse().unwrap();
        assert_eq!(l, FetchLimit::Size(CacheSize::Bytes(1 << 20)));
        assert_eq!(l.resolve(1 << 30, None), Some(1 << 20));
        let l: FetchLimit = "5%".parse().unwrap();
        assert_eq!(l.resolve(1000, Some(10)), Some(50));
        let l: FetchLimit = " Unlimited ".parse().unwrap();
        assert_eq!(l.resolve(1000, Some(10)), None);
        let e = "lots".parse::<FetchLimit>().unwrap_err();
        assert!(e.contains("\"lots\"") && e.contains("auto"), "{e}");
    }
}
