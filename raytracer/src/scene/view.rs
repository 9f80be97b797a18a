//! Views after Radiance: projection types, view options (`-vtv -vp ...`),
//! view files (as written by `rview`/`rvu`), primary rays, and the
//! resolution/aspect fit `rpict` does.
//!
//! Image coordinates are normalised: `x` in `[0, 1]` from left to right, `y`
//! in `[0, 1]` from bottom to top (Radiance's convention: `(0, 0)` is the
//! bottom-left corner). With `x' = x - 0.5 + vs` and `y' = y - 0.5 + vl`,
//! and the unit vectors `d` (view direction), `h` (right, `d x vu`) and `u`
//! (up, `h x d`), the ray directions are:
//!
//! | type | `-vt` | direction (before normalising) | `vh`, `vv` |
//! |------|-------|--------------------------------|------------|
//! | perspective   | `v` | `d + 2x' tan(vh/2) h + 2y' tan(vv/2) u` | degrees, (0, 180) |
//! | parallel      | `l` | `d`, from `vp + x' vh h + y' vv u`      | world units, > 0 |
//! | angular fisheye | `a` | angle `r = |(x' vh, y' vv)|` from `d` towards `(x', y')`; none past 180 degrees | degrees, (0, 360] |
//! | hemispherical | `h` | `z d + 2x' sin(vh/2) h + 2y' sin(vv/2) u`, `z = sqrt(1 - ...)`; none where `z` is imaginary | degrees, (0, 180] |
//! | cylindrical panorama | `c` | `cos(x' vh) d + sin(x' vh) h + 2y' tan(vv/2) u` | vh (0, 360], vv (0, 180) |
//! | stereographic | `s` | angle `2 atan(k)` from `d`, `k = |(2x' tan(vh/4), 2y' tan(vv/4))|` | degrees, (0, 360) |
//!
//! so every type spans exactly `vh` horizontally and `vv` vertically across
//! the image. `-vo` and `-va` clip the ray: for perspective views they are
//! distances of planes perpendicular to `d` (Radiance's convention), for the
//! others distances along the ray; `-va 0` means no aft clipping.

use std::path::{Path, PathBuf};

use crate::geometry::{Ray, Vec3};
use crate::{Error, Result, SourceLoc};

/// Projection types, by Radiance's `-vt` letter.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum ViewType {
    /// `v`: perspective.
    Perspective,
    /// `l`: parallel (orthographic).
    Parallel,
    /// `a`: angular fisheye (equidistant).
    Angular,
    /// `h`: hemispherical fisheye (orthographic projection of the hemisphere).
    Hemispherical,
    /// `c`: cylindrical panorama.
    Cylindrical,
    /// `s`: stereographic (planisphere) fisheye.
    Stereographic,
}

impl ViewType {
    pub fn letter(self) -> char {
        match self {
            ViewType::Perspective => 'v',
            ViewType::Parallel => 'l',
            ViewType::Angular => 'a',
            ViewType::Hemispherical => 'h',
            ViewType::Cylindrical => 'c',
            ViewType::Stereographic => 's',
        }
    }

    pub fn from_letter(c: char) -> Option<Self> {
        Some(match c {
            'v' => ViewType::Perspective,
            'l' => ViewType::Parallel,
            'a' => ViewType::Angular,
            'h' => ViewType::Hemispherical,
            'c' => ViewType::Cylindrical,
            's' => ViewType::Stereographic,
            _ => return None,
        })
    }
}

/// A Radiance view. Field names follow the options (`vp` is `-vp`, ...).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct View {
    pub vtype: ViewType,
    /// View point.
    pub vp: Vec3,
    /// View direction (need not be unit length).
    pub vd: Vec3,
    /// View up vector.
    pub vu: Vec3,
    /// Horizontal size: degrees, or world units for parallel views.
    pub vh: f64,
    /// Vertical size: degrees, or world units for parallel views.
    pub vv: f64,
    /// Horizontal shift, in image widths.
    pub vs: f64,
    /// Vertical lift, in image heights.
    pub vl: f64,
    /// Fore clipping distance.
    pub vo: f64,
    /// Aft clipping distance (0: none).
    pub va: f64,
}

impl Default for View {
    /// Radiance's default view: `-vtv -vp 0 0 0 -vd 0 1 0 -vu 0 0 1 -vh 45 -vv 45`.
    fn default() -> Self {
        View {
            vtype: ViewType::Perspective,
            vp: Vec3::ZERO,
            vd: Vec3::Y,
            vu: Vec3::Z,
            vh: 45.0,
            vv: 45.0,
            vs: 0.0,
            vl: 0.0,
            vo: 0.0,
            va: 0.0,
        }
    }
}

/// A number as `%g` writes it, near enough: exponent form when large.
fn g(x: f64) -> String {
    if x.is_finite() && x != 0.0 && !(1e-4..1e6).contains(&x.abs()) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

/// The line of view file `path` an invalid view is blamed on: the last
/// line setting the option the reason names (`-vh ...`), else the last line
/// with view options; 0 when the file cannot be read again.
fn blame_line(path: &Path, reason: &str) -> usize {
    match super::input::read_input_text(path, super::input::MAX_VIEW_BYTES) {
        Ok(text) => blame_in(&text, reason),
        Err(_) => 0,
    }
}

/// [`blame_line`] for a view file's text.
fn blame_in(text: &str, reason: &str) -> usize {
    let option = reason
        .split(|c: char| c.is_whitespace() || c == '(' || c == ':')
        .find(|w| w.len() >= 3 && w.starts_with("-v"))
        .map(|w| if w.starts_with("-vt") { "-vt" } else { w });
    let mut last = 0;
    let mut last_option = 0;
    for (k, line) in text.lines().enumerate() {
        let line = line.split('#').next().unwrap_or("");
        let mut words = line.split_whitespace().peekable();
        if words.peek().is_some() {
            last = k + 1;
        }
        if let Some(o) = option {
            if line.split_whitespace().any(|w| w.starts_with(o)) {
                last_option = k + 1;
            }
        }
    }
    if last_option > 0 {
        last_option
    } else {
        last
    }
}

/// Deepest `-vf` nesting.
const MAX_VF_DEPTH: usize = 8;

/// Largest view file read, in bytes.
const MAX_VIEW_FILE: u64 = 1 << 20;

/// Largest Radiance picture header read for its `VIEW=` lines, in bytes.
const MAX_PICTURE_HEADER: u64 = 64 << 10;

/// The text of a view file. A Radiance picture (starting `#?`) gives its
/// header's `VIEW=` lines (the header is the text up to the first empty
/// line; the pixels after it are never read), every other header line
/// left empty so line numbers stay right. Only regular files are read,
/// and no more than [`MAX_VIEW_FILE`] bytes ([`MAX_PICTURE_HEADER`] of a
/// picture's header).
fn read_view_text(path: &Path) -> std::io::Result<String> {
    use std::io::{BufRead, BufReader, Error as IoError, ErrorKind, Read};
    let file = std::fs::File::open(path)?;
    if !file.metadata()?.is_file() {
        return Err(IoError::new(ErrorKind::InvalidInput, "not a regular file"));
    }
    let mut r = BufReader::new(file);
    if r.fill_buf()?.starts_with(b"#?") {
        let mut header = Vec::new();
        let mut text = String::new();
        let mut found = false;
        let mut limited = r.take(MAX_PICTURE_HEADER);
        loop {
            header.clear();
            if limited.read_until(b'\n', &mut header)? == 0 || !header.ends_with(b"\n") {
                return Err(IoError::new(
                    ErrorKind::InvalidData,
                    format!(
                        "Radiance picture header not ended by an empty line within {} KiB",
                        MAX_PICTURE_HEADER >> 10
                    ),
                ));
            }
            let line = String::from_utf8_lossy(&header);
            let line = line.trim_end_matches(['\n', '\r']);
            if line.is_empty() {
                break;
            }
            if line.trim_start().starts_with("VIEW=") {
                text.push_str(line.trim_start());
                found = true;
            }
            text.push('\n');
        }
        if !found {
            return Err(IoError::new(
                ErrorKind::InvalidData,
                "Radiance picture without a VIEW= line in its header",
            ));
        }
        return Ok(text);
    }
    let mut bytes = Vec::new();
    r.take(MAX_VIEW_FILE + 1).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > MAX_VIEW_FILE {
        return Err(IoError::new(
            ErrorKind::InvalidData,
            format!("larger than {} KiB: not a view file", MAX_VIEW_FILE >> 10),
        ));
    }
    String::from_utf8(bytes)
        .map_err(|_| IoError::new(ErrorKind::InvalidData, "not text (invalid UTF-8)"))
}

/// Program names a view line may start with.
const PROGRAMS: &[&str] = &["rview", "rvu", "rpict", "rtrace", "rtpict", "VIEW="];

impl View {
    /// Parses view options (e.g. `"-vtv -vp 0 0 1 -vd 0 1 0 -vh 60"`) on top
    /// of the default view and validates the result. `-vf file` reads a view
    /// file relative to the current directory.
    pub fn from_options(options: &str) -> Result<View> {
        let mut v = View::default();
        v.apply_options(options, &SourceLoc::new("<view options>", 1))?;
        v.validate()
            .map_err(|r| Error::parse(SourceLoc::new("<view options>", 1), r))?;
        Ok(v)
    }

    /// Reads a view file (one or more lines of view options, each optionally
    /// starting with a program name such as `rview`), validating the result.
    pub fn from_file(path: impl AsRef<Path>) -> Result<View> {
        let path = path.as_ref();
        let mut v = View::default();
        v.apply_file(path, None, 0)?;
        v.validate()
            .map_err(|r| Error::parse(SourceLoc::new(path, blame_line(path, &r)), r))?;
        Ok(v)
    }

    /// Applies view options to this view (no validation). `loc` names where
    /// the options came from; `-vf` files are resolved relative to its file.
    pub fn apply_options(&mut self, options: &str, loc: &SourceLoc) -> Result<()> {
        let words: Vec<&str> = options.split_whitespace().collect();
        self.apply_words(&words, loc, 0)
    }

    /// A view file's text held in memory (tests, fuzzing): the lines of
    /// [`View::from_file`], with `path` naming it in errors and resolving
    /// its `-vf` files.
    pub fn from_file_text(text: &str, path: impl AsRef<Path>) -> Result<View> {
        let path = path.as_ref();
        let mut v = View::default();
        v.apply_text(text, path, 0)?;
        v.validate()
            .map_err(|r| Error::parse(SourceLoc::new(path, blame_in(text, &r)), r))?;
        Ok(v)
    }

    fn apply_file(&mut self, path: &Path, from: Option<&SourceLoc>, depth: usize) -> Result<()> {
        let text = read_view_text(path).map_err(|e| match from {
            Some(loc) => Error::parse(
                loc.clone(),
                format!("cannot read view file '{}': {e}", path.display()),
            ),
            None => Error::io(path, e),
        })?;
        self.apply_text(&text, path, depth)
    }

    fn apply_text(&mut self, text: &str, path: &Path, depth: usize) -> Result<()> {
        for (k, line) in text.lines().enumerate() {
            let loc = SourceLoc::new(path, k + 1);
            let line = line.split('#').next().unwrap_or("");
            let mut words: Vec<&str> = line.split_whitespace().collect();
            if let Some(first) = words.first() {
                let prog = first.rsplit('/').next().unwrap_or(first);
                if PROGRAMS.contains(&prog) {
                    words.remove(0);
                } else if let Some(rest) = first.strip_prefix("VIEW=") {
                    words[0] = rest;
                }
            }
            self.apply_words(&words, &loc, depth)?;
        }
        Ok(())
    }

    fn apply_words(&mut self, words: &[&str], loc: &SourceLoc, depth: usize) -> Result<()> {
        let err = |r: String| Error::parse(loc.clone(), r);
        let num = |i: usize, opt: &str| -> Result<f64> {
            let w = words
                .get(i)
                .ok_or_else(|| err(format!("view option {opt}: missing number")))?;
            super::rad::parse_real(w).map_err(|r| {
                err(format!(
                    "view option {opt}: {}",
                    r.replace("real argument", "number")
                ))
            })
        };
        let vec3 = |i: usize, opt: &str| -> Result<Vec3> {
            Ok(Vec3::new(num(i, opt)?, num(i + 1, opt)?, num(i + 2, opt)?))
        };
        let mut i = 0;
        while i < words.len() {
            let w = words[i];
            match w {
                "-vp" | "-vd" | "-vu" => {
                    let v = vec3(i + 1, w)?;
                    match w {
                        "-vp" => self.vp = v,
                        "-vd" => self.vd = v,
                        _ => self.vu = v,
                    }
                    i += 4;
                }
                "-vh" | "-vv" | "-vs" | "-vl" | "-vo" | "-va" => {
                    let x = num(i + 1, w)?;
                    match w {
                        "-vh" => self.vh = x,
                        "-vv" => self.vv = x,
                        "-vs" => self.vs = x,
                        "-vl" => self.vl = x,
                        "-vo" => self.vo = x,
                        _ => self.va = x,
                    }
                    i += 2;
                }
                "-vf" => {
                    let f = words
                        .get(i + 1)
                        .ok_or_else(|| err("view option -vf: missing file name".into()))?;
                    if depth >= MAX_VF_DEPTH {
                        return Err(err(format!(
                            "view files nested deeper than {MAX_VF_DEPTH} (a -vf cycle?)"
                        )));
                    }
                    let base: PathBuf = super::rad::base_dir_of(&loc.file);
                    self.apply_file(&base.join(f), Some(loc), depth + 1)?;
                    i += 2;
                }
                _ => {
                    let t = w.strip_prefix("-vt").and_then(|r| {
                        let mut c = r.chars();
                        match (c.next(), c.next()) {
                            (Some(l), None) => ViewType::from_letter(l),
                            _ => None,
                        }
                    });
                    match t {
                        Some(t) => self.vtype = t,
                        None if w.starts_with("-vt") => {
                            return Err(err(format!("unknown view type '{w}' (expected -vtv, -vtl, -vta, -vth, -vtc or -vts)")))
                        }
                        None => return Err(err(format!("unknown view option '{w}'"))),
                    }
                    i += 1;
                }
            }
        }
        Ok(())
    }

    /// Checks the view: finite values, `vd` non-zero, `vu` not parallel to
    /// `vd`, sizes in range for the type, `0 <= vo < va` (unless `va == 0`).
    pub fn validate(&self) -> std::result::Result<(), String> {
        // Radiance's FHUGE: larger positions and sizes lose all precision
        // (a parallel view 1e308 wide renders black).
        const HUGE: f64 = 1e10;
        let vectors = [("-vp", self.vp), ("-vd", self.vd), ("-vu", self.vu)];
        for (name, v) in vectors {
            if !v.is_finite() || v.abs().max_element() >= HUGE {
                return Err(format!(
                    "{name} {} {} {}: view parameters must be finite and below {HUGE:e}",
                    g(v.x),
                    g(v.y),
                    g(v.z)
                ));
            }
        }
        let all = [
            ("-vh", self.vh),
            ("-vv", self.vv),
            ("-vs", self.vs),
            ("-vl", self.vl),
            ("-vo", self.vo),
            ("-va", self.va),
        ];
        for (name, x) in all {
            if !x.is_finite() || x.abs() >= HUGE {
                return Err(format!(
                    "{name} {}: view parameters must be finite and below {HUGE:e}",
                    g(x)
                ));
            }
        }
        if self.vd.length() == 0.0 || !self.vd.length().is_finite() {
            return Err("view direction (-vd) is zero".into());
        }
        let d = self.vd.normalize();
        if self.vu.length() == 0.0
            || !self.vu.length().is_finite()
            || self.vu.normalize().cross(d).length() < 1e-6
        {
            return Err(
                "view up vector (-vu) is zero or parallel to the view direction (-vd)".into(),
            );
        }
        let range = |name: &str, x: f64, lo: f64, hi: f64, hi_incl: bool| {
            if x > lo && (x < hi || (hi_incl && x == hi)) {
                Ok(())
            } else {
                let close = if hi_incl { "]" } else { ")" };
                Err(format!(
                    "{name} {x} is out of range ({lo}, {hi}{close} for view type -vt{}",
                    self.vtype.letter()
                ))
            }
        };
        match self.vtype {
            ViewType::Perspective => {
                range("-vh", self.vh, 0.0, 180.0, false)?;
                range("-vv", self.vv, 0.0, 180.0, false)?;
            }
            ViewType::Parallel => {
                range("-vh", self.vh, 0.0, f64::INFINITY, false)?;
                range("-vv", self.vv, 0.0, f64::INFINITY, false)?;
            }
            ViewType::Angular => {
                range("-vh", self.vh, 0.0, 360.0, true)?;
                range("-vv", self.vv, 0.0, 360.0, true)?;
            }
            ViewType::Hemispherical => {
                range("-vh", self.vh, 0.0, 180.0, true)?;
                range("-vv", self.vv, 0.0, 180.0, true)?;
            }
            ViewType::Cylindrical => {
                range("-vh", self.vh, 0.0, 360.0, true)?;
                range("-vv", self.vv, 0.0, 180.0, false)?;
            }
            ViewType::Stereographic => {
                range("-vh", self.vh, 0.0, 360.0, false)?;
                range("-vv", self.vv, 0.0, 360.0, false)?;
            }
        }
        if self.vo < 0.0 {
            return Err(format!(
                "fore clipping distance -vo {} is negative",
                self.vo
            ));
        }
        if self.va != 0.0 && self.va <= self.vo {
            return Err(format!(
                "aft clipping distance -va {} must exceed -vo {} (or be 0)",
                self.va, self.vo
            ));
        }
        Ok(())
    }

    /// The orthonormal frame `(d, h, u)`: view direction, right, up.
    pub fn frame(&self) -> (Vec3, Vec3, Vec3) {
        let d = self.vd.normalize();
        let h = d.cross(self.vu).normalize();
        let u = h.cross(d);
        (d, h, u)
    }

    /// The primary ray through normalised image point `(x, y)` (`x` to the
    /// right, `y` up, `(0, 0)` the bottom-left corner) and its valid
    /// distance range `(tmin, tmax)` from `-vo`/`-va` (`tmax` infinite when
    /// `va == 0`). `None` where the point lies outside the projection (the
    /// corners of fisheye views). The view must be valid ([`View::validate`]).
    pub fn ray(&self, x: f64, y: f64) -> Option<(Ray, f64, f64)> {
        let (d, h, u) = self.frame();
        let xp = x - 0.5 + self.vs;
        let yp = y - 0.5 + self.vl;
        let half = |deg: f64| (deg * 0.5).to_radians();
        let mut origin = self.vp;
        let dir = match self.vtype {
            ViewType::Perspective => {
                d + h * (2.0 * xp * half(self.vh).tan()) + u * (2.0 * yp * half(self.vv).tan())
            }
            ViewType::Parallel => {
                origin += h * (xp * self.vh) + u * (yp * self.vv);
                d
            }
            ViewType::Angular => {
                let ax = xp * self.vh.to_radians();
                let ay = yp * self.vv.to_radians();
                let r = (ax * ax + ay * ay).sqrt();
                if r > std::f64::consts::PI {
                    return None;
                }
                let s = if r == 0.0 { 1.0 } else { r.sin() / r };
                d * r.cos() + h * (ax * s) + u * (ay * s)
            }
            ViewType::Hemispherical => {
                let hx = 2.0 * xp * half(self.vh).sin();
                let hy = 2.0 * yp * half(self.vv).sin();
                let z2 = 1.0 - hx * hx - hy * hy;
                if z2 < 0.0 {
                    return None;
                }
                d * z2.sqrt() + h * hx + u * hy
            }
            ViewType::Cylindrical => {
                let phi = xp * self.vh.to_radians();
                d * phi.cos() + h * phi.sin() + u * (2.0 * yp * half(self.vv).tan())
            }
            ViewType::Stereographic => {
                let kx = 2.0 * xp * (self.vh * 0.25).to_radians().tan();
                let ky = 2.0 * yp * (self.vv * 0.25).to_radians().tan();
                let k2 = kx * kx + ky * ky;
                let z = (1.0 - k2) / (1.0 + k2);
                d * z + (h * kx + u * ky) * (1.0 + z)
            }
        };
        let len = dir.length();
        if len == 0.0 || !len.is_finite() {
            return None;
        }
        // Perspective clipping planes are perpendicular to d: the distance
        // along the ray is the plane distance times |dir| (dir . d == 1).
        let k = if self.vtype == ViewType::Perspective {
            len
        } else {
            1.0
        };
        let tmax = if self.va > 0.0 {
            self.va * k
        } else {
            f64::INFINITY
        };
        Some((
            Ray {
                origin,
                dir: dir / len,
            },
            self.vo * k,
            tmax,
        ))
    }

    /// Image height over width that gives square pixels for this view
    /// (Radiance's `viewaspect`).
    pub fn aspect(&self) -> f64 {
        let t = |deg: f64| (deg * 0.5).to_radians().tan();
        let s = |deg: f64| (deg * 0.5).to_radians().sin();
        match self.vtype {
            ViewType::Perspective => t(self.vv) / t(self.vh),
            ViewType::Parallel | ViewType::Angular => self.vv / self.vh,
            ViewType::Hemispherical => s(self.vv) / s(self.vh),
            ViewType::Cylindrical => 2.0 * t(self.vv) / self.vh.to_radians(),
            ViewType::Stereographic => {
                (self.vv * 0.25).to_radians().tan() / (self.vh * 0.25).to_radians().tan()
            }
        }
    }

    /// Fits a resolution to the view like `rpict`'s `normaspect` with pixel
    /// aspect 1: `width` and `height` are maxima; the one that is too large
    /// for the view's aspect ([`View::aspect`], height/width) is reduced
    /// (rounded, at least 1) so that pixels are square. The view itself is
    /// returned unchanged (angles are never altered to fill a resolution).
    pub fn fit_aspect(&self, width: u32, height: u32) -> (View, u32, u32) {
        let a = self.aspect();
        let (w, h) = (width.max(1) as f64, height.max(1) as f64);
        if !(a.is_finite() && a > 0.0) {
            return (self.clone(), width.max(1), height.max(1));
        }
        let (w2, h2) = if h / w > a {
            (w, (w * a).round().max(1.0))
        } else {
            ((h / a).round().max(1.0), h)
        };
        (self.clone(), w2 as u32, h2 as u32)
    }

    /// A perspective view (Radiance's 45 by 45 degrees) that sees the whole
    /// box `min`..`max` with `up` up: from the front and a little above,
    /// at the distance where the box's bounding sphere fills the view. The
    /// front is +z for a y up axis (OBJ's convention), -y for z up (as
    /// Radiance's default view looks along +y) and +z for x up. An empty
    /// or non-finite box is taken as the unit cube around the origin.
    pub fn framing(min: Vec3, max: Vec3, up: Vec3) -> View {
        let ok = min.is_finite() && max.is_finite() && min.cmple(max).all();
        let (centre, radius) = if ok {
            ((min + max) * 0.5, (max - min).length() * 0.5)
        } else {
            (Vec3::ZERO, 0.0)
        };
        let radius = if radius > 0.0 && radius.is_finite() {
            radius
        } else {
            1.0
        };
        let up = up.normalize_or(Vec3::Y);
        let front = if up.z.abs() > 0.5 { -Vec3::Y } else { Vec3::Z };
        let from = (front + up * 0.5).normalize();
        let v = View::default();
        let distance = radius / (v.vh * 0.5).to_radians().sin();
        // (+ 0.0 turns -0 into 0 for the VIEW= line.)
        View {
            vp: centre + from * distance + Vec3::ZERO,
            vd: -from + Vec3::ZERO,
            vu: up + Vec3::ZERO,
            ..v
        }
    }

    /// The view as Radiance options (`-vtv -vp ... -va ...`).
    pub fn to_options(&self) -> String {
        let v = |a: Vec3| format!("{} {} {}", a.x, a.y, a.z);
        format!(
            "-vt{} -vp {} -vd {} -vu {} -vh {} -vv {} -vs {} -vl {} -vo {} -va {}",
            self.vtype.letter(),
            v(self.vp),
            v(self.vd),
            v(self.vu),
            self.vh,
            self.vv,
            self.vs,
            self.vl,
            self.vo,
            self.va
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: Vec3, b: Vec3) -> bool {
        (a - b).abs().max_element() < 1e-12
    }

    fn view(opts: &str) -> View {
        View::from_options(&format!("-vp 0 0 0 -vd 0 1 0 -vu 0 0 1 {opts}")).unwrap()
    }

    fn dir(v: &View, x: f64, y: f64) -> Vec3 {
        v.ray(x, y).expect("inside the view").0.dir
    }

    #[test]
    fn perspective_directions() {
        let v = view("-vtv -vh 90 -vv 90");
        let s = std::f64::consts::FRAC_1_SQRT_2;
        assert!(close(dir(&v, 0.5, 0.5), Vec3::Y));
        assert!(
            close(dir(&v, 1.0, 0.5), Vec3::new(s, s, 0.0)),
            "x grows to the right"
        );
        assert!(
            close(dir(&v, 0.5, 1.0), Vec3::new(0.0, s, s)),
            "y grows upwards"
        );
        let k = 1.0 / 3f64.sqrt();
        assert!(
            close(dir(&v, 0.0, 0.0), Vec3::new(-k, k, -k)),
            "(0,0) is bottom left"
        );
        // Shift and lift move the image window by whole image sizes.
        let w = view("-vtv -vh 90 -vv 90 -vs 0.5 -vl -0.5");
        assert!(close(dir(&w, 0.5, 0.5), dir(&v, 1.0, 0.0)));
    }

    #[test]
    fn parallel_origins() {
        let v = view("-vtl -vh 4 -vv 2");
        let (r, _, _) = v.ray(1.0, 1.0).unwrap();
        assert!(close(r.origin, Vec3::new(2.0, 0.0, 1.0)));
        assert!(close(r.dir, Vec3::Y));
        let (r, _, _) = v.ray(0.0, 0.5).unwrap();
        assert!(close(r.origin, Vec3::new(-2.0, 0.0, 0.0)));
    }

    #[test]
    fn angular_fisheye() {
        let v = view("-vta -vh 180 -vv 180");
        assert!(close(dir(&v, 1.0, 0.5), Vec3::X));
        assert!(close(dir(&v, 0.5, 0.0), -Vec3::Z));
        let a = (std::f64::consts::PI / 4.0).sin();
        assert!(close(dir(&v, 0.75, 0.5), Vec3::new(a, a, 0.0)));
        let full = view("-vta -vh 360 -vv 360");
        assert!(close(dir(&full, 1.0, 0.5), -Vec3::Y));
        assert!(full.ray(1.0, 1.0).is_none(), "corner beyond 180 degrees");
    }

    #[test]
    fn hemispherical_fisheye() {
        let v = view("-vth -vh 180 -vv 180");
        assert!(close(dir(&v, 1.0, 0.5), Vec3::X));
        assert!(close(
            dir(&v, 0.75, 0.5),
            Vec3::new(0.5, 0.75f64.sqrt(), 0.0)
        ));
        assert!(v.ray(1.0, 1.0).is_none(), "corner outside the hemisphere");
    }

    #[test]
    fn cylindrical_panorama() {
        let v = view("-vtc -vh 360 -vv 90");
        assert!(close(dir(&v, 0.75, 0.5), Vec3::X));
        assert!(close(dir(&v, 1.0, 0.5), -Vec3::Y));
        let s = std::f64::consts::FRAC_1_SQRT_2;
        assert!(close(dir(&v, 0.5, 1.0), Vec3::new(0.0, s, s)));
    }

    #[test]
    fn stereographic() {
        let v = view("-vts -vh 180 -vv 180");
        assert!(close(dir(&v, 0.5, 0.5), Vec3::Y));
        assert!(close(dir(&v, 1.0, 0.5), Vec3::X));
        // Angle 45 degrees up: k = tan(22.5 deg) = 2 y' tan(180/4 deg) = 2 y'.
        let y = 0.5 + 22.5f64.to_radians().tan() / 2.0;
        let a = std::f64::consts::FRAC_1_SQRT_2;
        assert!(close(dir(&v, 0.5, y), Vec3::new(0.0, a, a)));
    }

    #[test]
    fn clipping_distances() {
        let v = view("-vtv -vh 90 -vv 90 -vo 1 -va 5");
        let (_, t0, t1) = v.ray(1.0, 0.5).unwrap();
        let l = 2f64.sqrt();
        assert!(
            (t0 - l).abs() < 1e-12 && (t1 - 5.0 * l).abs() < 1e-12,
            "planes perpendicular to vd"
        );
        let (_, t0, t1) = view("-vta -vh 180 -vv 180 -vo 1 -va 5")
            .ray(1.0, 0.5)
            .unwrap();
        assert_eq!((t0, t1), (1.0, 5.0));
        let (_, _, t1) = view("-vtv").ray(0.5, 0.5).unwrap();
        assert_eq!(t1, f64::INFINITY);
    }

    #[test]
    fn fit_aspect_makes_square_pixels() {
        let v = view("-vtv -vh 90 -vv 90");
        assert_eq!(
            v.fit_aspect(512, 400).1..=v.fit_aspect(512, 400).2,
            400..=400
        );
        let w = view("-vtv -vh 90 -vv 53.130102354155985"); // tan(vv/2) = 0.5
        let (_, x, y) = w.fit_aspect(512, 512);
        assert_eq!((x, y), (512, 256));
        let p = view("-vtl -vh 4 -vv 1");
        assert_eq!(&p.fit_aspect(100, 100).1, &100);
        assert_eq!(p.fit_aspect(100, 100).2, 25);
        assert_eq!(p.fit_aspect(10, 100).2, 3); // 2.5 rounds to 3 (away from zero)
    }

    #[test]
    fn radiance_view_file_with_program_name() {
        let p = Path::new("/work/shared/scenes/radiance-cornell/cornell.vf");
        let v = View::from_file(p).unwrap();
        assert_eq!(v.vtype, ViewType::Perspective);
        assert_eq!(v.vp, Vec3::new(0.49, 0.0, 0.0));
        assert_eq!(v.vd, Vec3::new(-1.0, 0.0, 0.0));
        assert_eq!((v.vh, v.vv, v.va), (80.0, 80.0, 0.0));
    }

    #[test]
    fn option_errors_name_the_problem() {
        let e = View::from_options("-vtq").unwrap_err().to_string();
        assert!(
            e.contains("<view options>:1") && e.contains("unknown view type '-vtq'"),
            "{e}"
        );
        let e = View::from_options("-vp 1 2").unwrap_err().to_string();
        assert!(e.contains("-vp: missing number"), "{e}");
        let e = View::from_options("-vh abc").unwrap_err().to_string();
        assert!(e.contains("-vh") && e.contains("'abc'"), "{e}");
        let e = View::from_options("-vd 0 0 0").unwrap_err().to_string();
        assert!(e.contains("-vd") && e.contains("zero"), "{e}");
        let e = View::from_options("-vd 0 0 1").unwrap_err().to_string();
        assert!(e.contains("parallel"), "{e}");
        let e = View::from_options("-vtv -vh 180").unwrap_err().to_string();
        assert!(e.contains("-vh 180 is out of range"), "{e}");
        assert!(View::from_options("-vta -vh 360 -vv 360").is_ok());
        let e = View::from_options("-vo 2 -va 1").unwrap_err().to_string();
        assert!(e.contains("-va"), "{e}");
        let e = View::from_options("-x 512").unwrap_err().to_string();
        assert!(e.contains("unknown view option '-x'"), "{e}");
    }

    #[test]
    fn sizes_outside_radiance_limits_are_refused() {
        for (opts, want) in [
            (
                "-vtl -vh 1e308",
                "-vh 1e308: view parameters must be finite and below 1e10",
            ),
            ("-vtl -vv 0", "-vv 0 is out of range"),
            ("-vtv -vh 179.99 -vv -1", "-vv -1 is out of range"),
            ("-vth -vh 181", "-vh 181 is out of range"),
            ("-vta -vv 361", "-vv 361 is out of range"),
            ("-vtc -vv 180", "-vv 180 is out of range"),
            ("-vts -vh 360", "-vh 360 is out of range"),
            (
                "-vp 1e300 0 0",
                "-vp 1e300 0 0: view parameters must be finite",
            ),
            ("-vo -1", "-vo -1 is negative"),
        ] {
            let e = View::from_options(opts).unwrap_err().to_string();
            assert!(e.contains(want), "{opts}: {e}");
        }
        assert!(View::from_options("-vtl -vh 1e9 -vv 1e9").is_ok());
        // View-file validation errors name the line setting the option.
        let dir = std::env::temp_dir().join(format!("hybrid-rt-view-blame-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("wide.vf");
        std::fs::write(&f, "rview -vtv -vp 0 0 0\n-vh 200\n-vv 40\n").unwrap();
        let e = View::from_file(&f).unwrap_err().to_string();
        assert!(e.contains("wide.vf:2: -vh 200 is out of range"), "{e}");
        std::fs::write(&f, "-vh 170\n-vv 40\n\n-vtl\n").unwrap();
        assert!(View::from_file(&f).is_ok());
        assert!(View::from_file("/dev/zero")
            .unwrap_err()
            .to_string()
            .contains("not a regular file"));
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn view_file_errors_have_file_and_line() {
        let dir = std::env::temp_dir().join(format!("hybrid-rt-view-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("bad.vf");
        std::fs::write(&f, "rview -vtv -vp 0 0 0\n# comment\nrpict -vh 50 bogus\n").unwrap();
        let e = View::from_file(&f).unwrap_err();
        match &e {
            Error::Parse { loc, reason } => {
                assert_eq!(loc.file, f);
                assert_eq!(loc.line, 3);
                assert!(reason.contains("unknown view option 'bogus'"), "{reason}");
            }
            other => panic!("{other:?}"),
        }
        // -vf includes, relative to the including file, and cycles stop.
        std::fs::write(dir.join("inner.vf"), "-vth -vh 180 -vv 180\n").unwrap();
        std::fs::write(dir.join("outer.vf"), "rvu -vf inner.vf -vp 1 2 3\n").unwrap();
        let v = View::from_file(dir.join("outer.vf")).unwrap();
        assert_eq!(
            (v.vtype, v.vp),
            (ViewType::Hemispherical, Vec3::new(1.0, 2.0, 3.0))
        );
        std::fs::write(dir.join("loop.vf"), "-vf loop.vf\n").unwrap();
        let e = View::from_file(dir.join("loop.vf"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("loop.vf:1") && e.contains("nested deeper"),
            "{e}"
        );
        let e = View::from_options("-vf /nonexistent/x.vf")
            .unwrap_err()
            .to_string();
        assert!(e.contains("cannot read view file"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn framing_sees_the_whole_box_from_the_front() {
        let (min, max) = (Vec3::new(-3.0, 1.0, 2.0), Vec3::new(5.0, 2.0, 4.0));
        for (up, front) in [(Vec3::Y, Vec3::Z), (Vec3::Z, -Vec3::Y), (-Vec3::X, Vec3::Z)] {
            let v = View::framing(min, max, up);
            v.validate().unwrap();
            assert_eq!(v.vu, up);
            let (d, h, u) = v.frame();
            assert!(d.dot(front) < -0.5, "looks towards -front");
            assert!(d.dot(up) < 0.0, "from above");
            let half = (v.vh * 0.5).to_radians().tan();
            for k in 0..8 {
                let c = Vec3::new(
                    if k & 1 == 0 { min.x } else { max.x },
                    if k & 2 == 0 { min.y } else { max.y },
                    if k & 4 == 0 { min.z } else { max.z },
                );
                let p = c - v.vp;
                let z = p.dot(d);
                assert!(z > 0.0);
                assert!((p.dot(h) / z).abs() < half && (p.dot(u) / z).abs() < half);
            }
        }
        // An empty box: the unit cube around the origin.
        let v = View::framing(Vec3::INFINITY, Vec3::NEG_INFINITY, Vec3::Y);
        assert!(v.validate().is_ok() && v.vp.is_finite());
    }
}
