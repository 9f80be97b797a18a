//! Tabulated Klems-basis BSDF files in LBNL's XML format (`bsdf.c`,
//! `bsdf_m.c`): [`KlemsData`] is a loaded file, the angle basis and, for
//! the visible (photopic, Radiance's "Y") data, up to four matrices (front
//! and back reflection, front and back transmission) with their Lambertian
//! minimum taken out (`extract_diffuse()`). The `BSDF` material that
//! shades with them is in the renderer (`render::bsdf`).

use std::f64::consts::PI;
use std::path::Path;

use crate::geometry::Vec3;

/// A Klems-style angle basis: latitude bands from the pole, each with a
/// number of azimuth patches (`ANGLE_BASIS` of `bsdf_m.c`).
#[derive(Debug, Clone, PartialEq)]
pub struct KlemsBasis {
    pub name: String,
    /// Lower theta (degrees) and patch count of each band, then the
    /// closing bound (90, 0). The first band's lower bound is the
    /// negated upper one, as Radiance stores it.
    pub lats: Vec<(f64, usize)>,
    pub n: usize,
}

impl KlemsBasis {
    /// The 145-patch "LBNL/Klems Full" basis.
    pub fn full() -> Self {
        let lats = vec![
            (-5.0, 1),
            (5.0, 8),
            (15.0, 16),
            (25.0, 20),
            (35.0, 24),
            (45.0, 24),
            (55.0, 24),
            (65.0, 16),
            (75.0, 12),
            (90.0, 0),
        ];
        Self {
            name: "LBNL/Klems Full".into(),
            n: lats.iter().map(|l| l.1).sum(),
            lats,
        }
    }

    /// The patch of a direction in the upper hemisphere (`ab_getndx`).
    pub fn index(&self, v: Vec3) -> Option<usize> {
        if !(v.z >= 0.0 && v.z <= 1.0) {
            return None;
        }
        let pol = v.z.acos().to_degrees();
        let mut azi = v.y.atan2(v.x).to_degrees();
        if azi < 0.0 {
            azi += 360.0;
        }
        let mut li = 1;
        while self.lats[li].0 <= pol {
            if self.lats[li].1 == 0 {
                return None;
            }
            li += 1;
        }
        li -= 1;
        let nphis = self.lats[li].1;
        let mut ndx = ((1.0 / 360.0) * azi * nphis as f64 + 0.5) as usize;
        if ndx >= nphis {
            ndx = 0;
        }
        Some(ndx + self.lats[..li].iter().map(|l| l.1).sum::<usize>())
    }

    fn band(&self, mut ndx: usize) -> (usize, usize) {
        let mut li = 0;
        while ndx >= self.lats[li].1 {
            ndx -= self.lats[li].1;
            li += 1;
        }
        (li, ndx)
    }

    /// Projected solid angle of patch `ndx` (`ab_getohm`).
    pub fn ohm(&self, ndx: usize) -> f64 {
        let (li, _) = self.band(ndx);
        let t1 = self.lats[li + 1].0.to_radians().cos();
        if self.lats[li].1 == 1 {
            return PI * (1.0 - t1 * t1);
        }
        let t0 = self.lats[li].0.to_radians().cos();
        PI * (t0 * t0 - t1 * t1) / self.lats[li].1 as f64
    }

    /// A direction in patch `ndx` at position (`r0`, `r1`) in [0, 1)²
    /// (`ab_getvec`).
    pub fn vec(&self, ndx: usize, r0: f64, r1: f64) -> Vec3 {
        let (li, k) = self.band(ndx);
        let pol = ((1.0 - r0) * self.lats[li].0 + r0 * self.lats[li + 1].0).to_radians();
        let azi = 2.0 * PI * (k as f64 + r1 - 0.5) / self.lats[li].1 as f64;
        let (s, c) = (pol.sin().abs(), pol.cos());
        Vec3::new(azi.cos() * s, azi.sin() * s, c)
    }
}

/// Which of the four scattering matrices.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Part {
    /// Reflection on the `+z` side (the XML's "Reflection Back").
    ReflFront = 0,
    /// Reflection on the `-z` side ("Reflection Front").
    ReflBack = 1,
    /// Transmission from `+z` to `-z` ("Transmission Front").
    TransFront = 2,
    /// Transmission from `-z` to `+z` ("Transmission Back").
    TransBack = 3,
}

impl Part {
    /// Whether the incident (`inc`) and outgoing (`out`) vectors of this
    /// matrix are reversed before indexing (`ab_getndxR`).
    fn reversed(self) -> (bool, bool) {
        match self {
            Part::ReflFront => (false, false),
            Part::ReflBack => (true, true),
            Part::TransFront => (false, true),
            Part::TransBack => (true, false),
        }
    }
}

/// One scattering matrix: values `[out * n + inc]` with the Lambertian
/// minimum subtracted, and that minimum times π (`cieY` of the diffuse
/// part).
#[derive(Debug, Clone)]
pub struct Matrix {
    pub values: Vec<f32>,
    pub lamb: f64,
    /// Largest directional-hemispherical sum of the non-diffuse part.
    pub max_hemi: f64,
}

/// A loaded BSDF file.
#[derive(Debug, Clone)]
pub struct KlemsData {
    pub path: String,
    pub basis: KlemsBasis,
    pub parts: [Option<Matrix>; 4],
}

fn child<'a>(n: roxmltree::Node<'a, 'a>, name: &str) -> Option<roxmltree::Node<'a, 'a>> {
    n.children().find(|c| c.tag_name().name() == name)
}

fn text<'a>(n: Option<roxmltree::Node<'a, 'a>>) -> &'a str {
    n.and_then(|n| n.text()).unwrap_or("").trim()
}

impl KlemsData {
    /// Reads a file (errors name it and say why).
    pub fn load(path: &Path) -> Result<Self, String> {
        let s = crate::input::read_input_text(path, crate::input::MAX_INPUT_BYTES)
            .map_err(|e| format!("cannot read BSDF file '{}': {e}", path.display()))?;
        Self::parse(&s, &path.display().to_string())
    }

    /// Parses the XML text of file `name` (`SDloadMtx`).
    pub fn parse(xml: &str, name: &str) -> Result<Self, String> {
        let err = |why: String| format!("BSDF file '{name}': {why}");
        let doc = roxmltree::Document::parse(xml).map_err(|e| err(format!("not XML: {e}")))?;
        let root = doc.root_element();
        if root.tag_name().name() != "WindowElement" {
            return Err(err(format!(
                "top element is <{}>, not <WindowElement>",
                root.tag_name().name()
            )));
        }
        let layer = child(root, "Optical")
            .and_then(|o| child(o, "Layer"))
            .ok_or_else(|| err("no <Optical><Layer>".into()))?;
        let def = child(layer, "DataDefinition")
            .ok_or_else(|| err("no <DataDefinition> (only matrix BSDFs are supported)".into()))?;
        let rows_in = match text(child(def, "IncidentDataStructure")) {
            s if s.eq_ignore_ascii_case("Columns") => false,
            s if s.eq_ignore_ascii_case("Rows") => true,
            "" => return Err(err("missing IncidentDataStructure".into())),
            s => {
                return Err(err(format!(
                    "unsupported IncidentDataStructure '{s}' (Columns or Rows are)"
                )))
            }
        };
        let ab = child(def, "AngleBasis").ok_or_else(|| err("missing AngleBasis".into()))?;
        let basis = Self::basis(ab).map_err(err)?;
        let mut parts: [Option<Matrix>; 4] = Default::default();
        let n = basis.n;
        for wd in layer
            .children()
            .filter(|c| c.tag_name().name() == "WavelengthData")
        {
            if !text(child(wd, "Wavelength")).eq_ignore_ascii_case("Visible") {
                continue; // only visible, as Radiance
            }
            for b in wd
                .children()
                .filter(|c| c.tag_name().name() == "WavelengthDataBlock")
            {
                let dir = text(child(b, "WavelengthDataDirection"));
                let part = match dir.to_ascii_lowercase().as_str() {
                    "reflection back" => Part::ReflFront,
                    "reflection front" => Part::ReflBack,
                    "transmission front" => Part::TransFront,
                    "transmission back" => Part::TransBack,
                    _ => return Err(err(format!("unknown WavelengthDataDirection '{dir}'"))),
                };
                for tag in ["ColumnAngleBasis", "RowAngleBasis"] {
                    let t = text(child(b, tag));
                    if !t.eq_ignore_ascii_case(&basis.name) {
                        return Err(err(format!(
                            "{dir}: {tag} '{t}' is not the defined basis '{}'",
                            basis.name
                        )));
                    }
                }
                let data = text(child(b, "ScatteringData"));
                let vals: Vec<&str> = data
                    .split(|c: char| c.is_whitespace() || c == ',')
                    .filter(|t| !t.is_empty())
                    .collect();
                if vals.len() != n * n {
                    return Err(err(format!(
                        "{dir}: ScatteringData has {} values, expected {} ({n} x {n})",
                        vals.len(),
                        n * n
                    )));
                }
                let mut values = vec![0f32; n * n];
                for (k, t) in vals.iter().enumerate() {
                    let v: f32 = t.parse().map_err(|_| {
                        err(format!(
                            "{dir}: ScatteringData value {} '{t}' is not a number",
                            k + 1
                        ))
                    })?;
                    if !v.is_finite() {
                        return Err(err(format!("{dir}: ScatteringData value {} is {v}", k + 1)));
                    }
                    let at = if rows_in { (k % n) * n + k / n } else { k };
                    values[at] = v;
                }
                // extract_diffuse(): the minimum is the Lambertian part.
                let minv = values.iter().copied().fold(f32::INFINITY, f32::min);
                for v in &mut values {
                    *v -= minv;
                }
                let ohm: Vec<f64> = (0..n).map(|o| basis.ohm(o)).collect();
                let max_hemi = (0..n)
                    .map(|i| {
                        (0..n)
                            .map(|o| ohm[o] * values[o * n + i] as f64)
                            .sum::<f64>()
                    })
                    .fold(0.0, f64::max);
                parts[part as usize] = Some(Matrix {
                    values,
                    lamb: minv as f64 * PI,
                    max_hemi,
                });
            }
        }
        if parts.iter().all(Option::is_none) {
            return Err(err("no visible scattering data".into()));
        }
        Ok(Self {
            path: name.to_string(),
            basis,
            parts,
        })
    }

    fn basis(ab: roxmltree::Node) -> Result<KlemsBasis, String> {
        let name = text(child(ab, "AngleBasisName")).to_string();
        if name.is_empty() {
            return Err("missing AngleBasisName".into());
        }
        let mut lats = Vec::new();
        let mut prev_upper = 0.0;
        for (i, b) in ab
            .children()
            .filter(|c| c.tag_name().name() == "AngleBasisBlock")
            .enumerate()
        {
            let tb = child(b, "ThetaBounds");
            let num = |tag: &str, n: Option<roxmltree::Node>| -> Result<f64, String> {
                text(n.and_then(|n| child(n, tag)))
                    .parse::<f64>()
                    .ok()
                    .filter(|t| t.is_finite())
                    .ok_or_else(|| format!("angle basis '{name}' block {}: bad {tag}", i + 1))
            };
            let upper = num("UpperTheta", tb)?;
            let lower = num("LowerTheta", tb)?;
            let nphis: usize = text(child(b, "nPhis"))
                .parse()
                .map_err(|_| format!("angle basis '{name}' block {}: bad nPhis", i + 1))?;
            if i == 0 {
                if nphis != 1 {
                    return Err(format!("angle basis '{name}': illegal phi count"));
                }
                lats.push((-upper, 1));
            } else {
                if nphis == 0 {
                    return Err(format!("angle basis '{name}': illegal phi count"));
                }
                if (lower - prev_upper).abs() > 1e-6 * prev_upper.abs().max(1.0) {
                    return Err(format!("angle basis '{name}': theta values disagree"));
                }
                lats.push((lower, nphis));
            }
            prev_upper = upper;
        }
        lats.push((prev_upper, 0));
        if lats.len() < 2 || lats.last().map(|l| l.0) != Some(90.0) {
            return Err(format!("angle basis '{name}' does not end at 90 degrees"));
        }
        // Contiguous bands.
        for w in lats.windows(2).skip(1) {
            if w[0].0 >= w[1].0 {
                return Err(format!("angle basis '{name}': theta bounds out of order"));
            }
        }
        let n = lats.iter().map(|l| l.1).sum();
        Ok(KlemsBasis { name, lats, n })
    }

    /// The matrix Radiance uses for incident `inc` and outgoing `out`
    /// local directions (`SDevalBSDF`): the side of each picks reflection
    /// front/back or transmission (falling back to the other
    /// transmission matrix when one is missing).
    pub fn part_for(&self, inc: Vec3, out: Vec3) -> Option<Part> {
        let (inf, outf) = (inc.z > 0.0, out.z > 0.0);
        let have = |p: Part| self.parts[p as usize].is_some();
        let p = match (inf, outf) {
            (true, true) => Part::ReflFront,
            (false, false) => Part::ReflBack,
            (true, false) => {
                if have(Part::TransFront) {
                    Part::TransFront
                } else {
                    Part::TransBack
                }
            }
            (false, true) => {
                if have(Part::TransBack) {
                    Part::TransBack
                } else {
                    Part::TransFront
                }
            }
        };
        have(p).then_some(p)
    }

    fn ndx(&self, v: Vec3, rev: bool) -> Option<usize> {
        self.basis.index(if rev { -v } else { v })
    }

    /// Non-diffuse BSDF value of `part` (`SDgetMtxBSDF`, with its
    /// reciprocity fallback).
    pub fn value(&self, part: Part, inc: Vec3, out: Vec3) -> f64 {
        let Some(m) = &self.parts[part as usize] else {
            return 0.0;
        };
        let (ri, ro) = part.reversed();
        let (i, o) = match (self.ndx(inc, ri), self.ndx(out, ro)) {
            (None, None) => (self.ndx(out, ri), self.ndx(inc, ro)),
            x => x,
        };
        match (i, o) {
            (Some(i), Some(o)) => m.values[o * self.basis.n + i] as f64,
            _ => 0.0,
        }
    }

    /// The Lambertian part (times π: a reflectance) for incident and
    /// outgoing sides, as `SDevalBSDF` adds it.
    pub fn lamb(&self, part: Part) -> f64 {
        self.parts[part as usize].as_ref().map_or(0.0, |m| m.lamb)
    }

    /// Directional-hemispherical sum of the non-diffuse part of `part`
    /// for the direction `v` (`SDdirectHemi`), and the column it sums:
    /// (incident index, sum over outgoing) or, when `v` is only an
    /// outgoing direction of the matrix, the reverse.
    fn column(&self, part: Part, v: Vec3) -> Option<(usize, bool)> {
        let (ri, ro) = part.reversed();
        if let Some(i) = self.ndx(v, ri) {
            return Some((i, false));
        }
        self.ndx(v, ro).map(|o| (o, true))
    }

    fn entry(&self, m: &Matrix, k: usize, j: usize, rev: bool) -> f64 {
        let n = self.basis.n;
        (if rev {
            m.values[k * n + j]
        } else {
            m.values[j * n + k]
        }) as f64
    }

    pub fn direct_hemi(&self, part: Part, v: Vec3) -> f64 {
        let Some(m) = &self.parts[part as usize] else {
            return 0.0;
        };
        let Some((k, rev)) = self.column(part, v) else {
            return 0.0;
        };
        (0..self.basis.n)
            .map(|j| self.entry(m, k, j, rev) * self.basis.ohm(j))
            .sum()
    }

    /// Samples a scattered direction for the direction `v` by the
    /// column's values times projected solid angles (`SDsampMtx`): the
    /// direction (pointing away from the surface on the scattered side)
    /// and the column's hemispherical sum.
    pub fn sample(&self, part: Part, v: Vec3, r: [f64; 3]) -> Option<(Vec3, f64)> {
        let m = self.parts[part as usize].as_ref()?;
        let (k, rev) = self.column(part, v)?;
        let n = self.basis.n;
        let total: f64 = (0..n)
            .map(|j| self.entry(m, k, j, rev) * self.basis.ohm(j))
            .sum();
        if total <= 1e-6 {
            return None;
        }
        let target = r[0].clamp(0.0, 0.999_999_999) * total;
        let mut acc = 0.0;
        let mut pick = n - 1;
        for j in 0..n {
            acc += self.entry(m, k, j, rev) * self.basis.ohm(j);
            if acc > target {
                pick = j;
                break;
            }
        }
        let (ri, ro) = part.reversed();
        let flip = if rev { ri } else { ro };
        let d = self.basis.vec(pick, r[1], r[2]);
        Some((if flip { -d } else { d }, total))
    }
}
