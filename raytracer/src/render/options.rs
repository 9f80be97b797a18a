//! Render options under Radiance's names and with `rpict`'s defaults.

use serde::{Deserialize, Serialize};

use crate::scene::Color;
use crate::{Error, Result};

/// Most ambient bounces accepted (`-ab`).
pub const MAX_AMBIENT_BOUNCES: u32 = 8;

/// Largest accepted image side, and pixel count.
pub const MAX_SIDE: usize = 1 << 16;
pub const MAX_PIXELS: usize = 1 << 28;
/// Most hemisphere rays per record (`-ad`, `-as`).
pub const MAX_AMBIENT_DIVISIONS: u32 = 1 << 16;
/// Most primary rays per pixel (`-pn`).
pub const MAX_PIXEL_SAMPLES: u32 = 4096;
/// Most rays one rough specular sample may take (`-ss`).
pub const MAX_SPECULAR_SAMPLES: f64 = 1024.0;

/// Rendering parameters. Field names follow Radiance's options (`-ds` is
/// `ds`, ...); defaults are `rpict`'s unless noted.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct RenderOptions {
    /// `-ds`: source subdivision ratio. An area source is split until every
    /// patch's size over its distance is below this (0 = never split).
    pub ds: f64,
    /// `-dj`: source jitter in [0, 1]: 0 aims at patch centres, 1 at a
    /// uniformly random point of each patch.
    pub dj: f64,
    /// `-dt`: direct threshold for adaptive shadow testing (0 = test all).
    pub dt: f64,
    /// `-dc`: direct certainty in [0, 1]: how far ahead in the sorted list
    /// the threshold test looks (`n^dc` patches, as Radiance's `direct()`).
    pub dc: f64,
    /// `-lr`: maximum reflection/refraction depth (primary rays are depth 0).
    pub lr: u32,
    /// `-lw`: minimum ray weight; lighter secondary rays are not traced.
    pub lw: f64,
    /// `-av`: constant ambient radiance, multiplied by diffuse reflectance.
    pub av: Color,
    /// `-aw`: weight of `-av` in the moving average with the irradiance
    /// cache's values that replaces it (Radiance's; 0, the default, keeps
    /// `-av` as given). See [`super::ambient::AmbientStore::ambient_value`].
    #[serde(default, skip_serializing_if = "is_zero")]
    pub aw: u32,
    /// `-ab`: ambient bounces: diffuse inter-reflection computed with an
    /// irradiance cache (see [`super::ambient`]); 0 uses the constant `-av`.
    pub ab: u32,
    /// `-aa`: ambient accuracy: the largest interpolation error accepted
    /// from the irradiance cache (Ward's `a`); 0 turns caching off (every
    /// diffuse point samples its own hemisphere).
    pub aa: f64,
    /// `-ar`: ambient resolution: records are at least scene size / `ar`
    /// apart (0: no lower limit).
    pub ar: u32,
    /// `-ad`: ambient divisions: hemisphere sample rays per record.
    pub ad: u32,
    /// `-as`: ambient super-samples: extra rays into the divisions whose
    /// neighbours differ most.
    #[serde(rename = "as")]
    pub as_: u32,
    /// `-st`: specular threshold: rough specular components at or below this
    /// are not sampled with a ray (their energy goes to the diffuse ambient).
    pub st: f64,
    /// `-ss`: specular sampling for rough specular rays: below 1, how far
    /// the one sampled ray is jittered; above 1.5, rays per rough
    /// reflection or transmission (times the ray's weight), as Radiance 5.
    pub ss: f64,
    /// Pixel samples (not an `rpict` option; `-pn` here): primary rays per
    /// pixel, averaged, each with its own jitter (`-pj`) and random stream.
    pub pn: u32,
    /// `-ps`: pixel sample spacing: above 1, pixels are traced on a grid of
    /// this spacing and in between only where neighbours differ by more
    /// than `-pt`, interpolated elsewhere (see [`super::adaptive`]).
    /// Default 1 here (every pixel traced; rpict's is 4).
    pub ps: u32,
    /// `-pt`: pixel sampling threshold: the relative difference between
    /// two samples above which the pixels between them are traced.
    pub pt: f64,
    /// `-pj`: pixel jitter in [0, 1]. Default 0 here (rpict uses 0.67) so a
    /// reference image samples pixel centres.
    pub pj: f64,
    /// Seed of all random streams (per pixel, derived from seed, x, y).
    pub seed: u64,
    /// `-dr`: source relays: how many mirrors and prisms a virtual light
    /// source may be relayed by (rpict's default 1; 0 = no virtual sources).
    pub dr: u32,
    /// `-bv`: back faces of plastic, metal and trans are visible (turned
    /// towards the ray); `-bv-` makes rays pass through them.
    pub bv: bool,
    /// `-me`: extinction coefficient (per unit length) of the global medium.
    pub me: Color,
    /// `-ma`: scattering albedo of the global medium.
    pub ma: Color,
    /// `-mg`: Henyey-Greenstein eccentricity of the global medium.
    pub mg: f64,
    /// `-ms`: sample spacing of light-source in-scattering in a medium
    /// (0: one sample per ray segment).
    pub ms: f64,
    /// `-i`: irradiance instead of radiance (Radiance's `do_irrad`): the
    /// first surface a primary ray meets, or reaches through pure
    /// transmission, is shaded as a white Lambertian (`Lamb`), so the
    /// picture's values are irradiance in W/m²; light sources keep their
    /// radiance, and glass, dielectric, interface, trans, trans2 and mist
    /// surfaces are passed through.
    pub irradiance: bool,
}

impl Default for RenderOptions {
    fn default() -> Self {
        Self {
            ds: 0.2,
            dj: 0.0,
            dt: 0.05,
            dc: 0.5,
            lr: 7,
            lw: 0.002,
            av: Color::ZERO,
            aw: 0,
            ab: 0,
            aa: 0.1,
            ar: 256,
            ad: 512,
            as_: 128,
            pn: 1,
            st: 0.15,
            ss: 1.0,
            ps: 1,
            pt: 0.05,
            pj: 0.0,
            seed: 0,
            dr: 1,
            bv: true,
            me: Color::ZERO,
            ma: Color::ZERO,
            mg: 0.0,
            ms: 0.0,
            irradiance: false,
        }
    }
}

/// Names of the quality presets ([`RenderOptions::preset`]).
pub const QUALITY_PRESETS: &[&str] = &["draft", "normal", "high"];

impl RenderOptions {
    /// A quality preset, chosen from the Pareto front of `hybrid-rt sweep`
    /// on the built-in scenes (book chapter "What accuracy costs"):
    /// - `draft`: coarse sources, lenient adaptive shadow testing and one
    ///   cheap ambient bounce;
    /// - `normal`: rpict's direct-light settings, two ambient bounces with
    ///   a coarse cache;
    /// - `high`: fine jittered sources, near-exhaustive shadow testing, two
    ///   ambient bounces, 4 jittered pixel samples.
    pub fn preset(name: &str) -> Result<Self> {
        let d = Self::default();
        Ok(match name.trim().to_ascii_lowercase().as_str() {
            "draft" => Self {
                ds: 0.5,
                dt: 0.3,
                ab: 1,
                aa: 0.3,
                ad: 64,
                as_: 16,
                ..d
            },
            "normal" => Self {
                ab: 2,
                aa: 0.2,
                ad: 128,
                as_: 32,
                ..d
            },
            "high" => Self {
                ds: 0.1,
                dt: 0.02,
                dj: 0.7,
                ab: 2,
                aa: 0.15,
                ad: 128,
                as_: 32,
                pn: 4,
                pj: 1.0,
                ..d
            },
            _ => {
                return Err(Error::Usage(format!(
                    "--quality {name:?}: expected one of {}",
                    QUALITY_PRESETS.join(", ")
                )))
            }
        })
    }
}

/// One Radiance option this renderer understands.
#[derive(Debug, Clone, Copy)]
pub struct RadianceOption {
    /// Name without the dash, as Radiance spells it (`ds`).
    pub name: &'static str,
    /// Number of values it takes.
    pub arity: usize,
    pub help: &'static str,
}

/// Every Radiance rendering option accepted by [`RenderOptions::set`].
pub const RADIANCE_OPTIONS: &[RadianceOption] = &[
    RadianceOption {
        name: "ds",
        arity: 1,
        help: "source subdivision ratio (default 0.2)",
    },
    RadianceOption {
        name: "dj",
        arity: 1,
        help: "source jitter 0..1 (default 0)",
    },
    RadianceOption {
        name: "dt",
        arity: 1,
        help: "direct threshold for adaptive shadow testing (default 0.05)",
    },
    RadianceOption {
        name: "dc",
        arity: 1,
        help: "direct certainty 0..1 (default 0.5)",
    },
    RadianceOption {
        name: "dr",
        arity: 1,
        help: "source relays through mirrors and prisms: virtual light sources (default 1)",
    },
    RadianceOption {
        name: "lr",
        arity: 1,
        help: "reflection depth limit (default 7)",
    },
    RadianceOption {
        name: "lw",
        arity: 1,
        help: "ray weight limit (default 0.002)",
    },
    RadianceOption {
        name: "av",
        arity: 3,
        help: "ambient value r g b (default 0 0 0)",
    },
    RadianceOption {
        name: "aw",
        arity: 1,
        help: "ambient value weight: -av joins a moving average of the computed ambient values with this weight, 0 = -av as given (default 0)",
    },
    RadianceOption {
        name: "ab",
        arity: 1,
        help: "ambient bounces: diffuse inter-reflection depth (default 0)",
    },
    RadianceOption {
        name: "aa",
        arity: 1,
        help: "ambient accuracy: irradiance cache interpolation error, 0 = no cache (default 0.1)",
    },
    RadianceOption {
        name: "ar",
        arity: 1,
        help: "ambient resolution: records at least scene size / ar apart (default 256)",
    },
    RadianceOption {
        name: "ad",
        arity: 1,
        help: "ambient divisions: hemisphere rays per record (default 512)",
    },
    RadianceOption {
        name: "as",
        arity: 1,
        help: "ambient super-samples (default 128)",
    },
    RadianceOption {
        name: "st",
        arity: 1,
        help: "specular threshold (default 0.15)",
    },
    RadianceOption {
        name: "ss",
        arity: 1,
        help: "specular sampling: jitter 0..1, or rays per rough specular sample above 1.5 (default 1)",
    },
    RadianceOption {
        name: "ps",
        arity: 1,
        help: "pixel sample spacing: trace a grid this far apart, refine where samples differ (default 1)",
    },
    RadianceOption {
        name: "pt",
        arity: 1,
        help: "pixel sampling threshold: relative difference that refines (default 0.05)",
    },
    RadianceOption {
        name: "pj",
        arity: 1,
        help: "pixel jitter 0..1 (default 0)",
    },
    RadianceOption {
        name: "dp",
        arity: 1,
        help: "virtual source pretest density: accepted, no effect (the pretest only drops relays that shadow rays find blocked anyway)",
    },
    RadianceOption {
        name: "af",
        arity: 1,
        help: "ambient file: `hybrid-rt render` reads the irradiance cache's records from it at the start and appends the new ones (Radiance 5's format); elsewhere (option strings, other commands) accepted with no effect",
    },
    RadianceOption {
        name: "u",
        arity: 0,
        help: "uncorrelated sampling -u+/-u-: accepted, no effect (renders stay reproducible from --seed)",
    },
    RadianceOption {
        name: "i",
        arity: 0,
        help: "irradiance: -i+ computes irradiance at the first surfaces seen (a white Lambertian), -i- radiance (default)",
    },
    RadianceOption {
        name: "bv",
        arity: 0,
        help: "back faces visible: -bv+ (default) or -bv- (rays pass through back faces)",
    },
    RadianceOption {
        name: "me",
        arity: 3,
        help: "global medium extinction per unit length r g b (default 0 0 0)",
    },
    RadianceOption {
        name: "ma",
        arity: 3,
        help: "global medium scattering albedo r g b (default 0 0 0)",
    },
    RadianceOption {
        name: "mg",
        arity: 1,
        help: "global medium scattering eccentricity -1..1 (default 0)",
    },
    RadianceOption {
        name: "ms",
        arity: 1,
        help: "medium in-scattering sample spacing (default 0: one sample per segment)",
    },
    RadianceOption {
        name: "pn",
        arity: 1,
        help: "pixel samples: primary rays per pixel, averaged (not in rpict; default 1)",
    },
];

/// A switch written with its state (`bv-`, `bv+`): the name and the state.
/// Whether `-aw` keeps its default (left out of serialized options, so
/// outputs written before it existed stay the same).
fn is_zero(x: &u32) -> bool {
    *x == 0
}

fn split_switch(name: &str) -> (&str, Option<bool>) {
    let is_switch = |n: &str| RADIANCE_OPTIONS.iter().any(|o| o.name == n && o.arity == 0);
    for (suffix, on) in [('+', true), ('-', false)] {
        if let Some(base) = name.strip_suffix(suffix) {
            if is_switch(base) {
                return (base, Some(on));
            }
        }
    }
    (name, None)
}

fn number(name: &str, s: &str) -> Result<f64> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(Error::Usage(format!(
            "-{name}: expected a finite number, got {s:?}"
        ))),
    }
}

fn integer(name: &str, s: &str) -> Result<u32> {
    s.trim().parse::<u32>().map_err(|_| {
        Error::Usage(format!(
            "-{name}: expected a non-negative integer, got {s:?}"
        ))
    })
}

fn in_range(name: &str, v: f64, lo: f64, hi: f64) -> Result<f64> {
    if (lo..=hi).contains(&v) {
        Ok(v)
    } else {
        Err(Error::Usage(format!(
            "-{name} {v}: must be between {lo} and {hi}"
        )))
    }
}

fn non_negative(name: &str, v: f64) -> Result<f64> {
    if v >= 0.0 {
        Ok(v)
    } else {
        Err(Error::Usage(format!("-{name} {v}: must not be negative")))
    }
}

impl RenderOptions {
    /// Sets the Radiance option `-name` from its textual values. Unknown
    /// names, wrong value counts, non-numbers, NaN, out-of-range values and
    /// features that are not implemented yet are usage errors.
    pub fn set(&mut self, name: &str, values: &[&str]) -> Result<()> {
        let name = name.trim_start_matches('-');
        let (name, switch) = split_switch(name);
        let Some(opt) = RADIANCE_OPTIONS.iter().find(|o| o.name == name) else {
            return Err(Error::Usage(format!("-{name}: unknown rendering option")));
        };
        if values.len() != opt.arity {
            return Err(Error::Usage(format!(
                "-{name} takes {} value(s), got {}",
                opt.arity,
                values.len()
            )));
        }
        if opt.arity == 0 {
            match name {
                "bv" => self.bv = switch.unwrap_or(!self.bv),
                "i" => self.irradiance = switch.unwrap_or(!self.irradiance),
                "u" => {}
                _ => unreachable!("option table and match disagree"),
            }
            return self.validate();
        }
        if switch.is_some() {
            return Err(Error::Usage(format!(
                "-{name}: takes values, not a + or - suffix"
            )));
        }
        let v0 = values[0];
        match name {
            "ds" => self.ds = non_negative(name, number(name, v0)?)?,
            "dj" => self.dj = in_range(name, number(name, v0)?, 0.0, 1.0)?,
            "dt" => self.dt = non_negative(name, number(name, v0)?)?,
            "dc" => self.dc = in_range(name, number(name, v0)?, 0.0, 1.0)?,
            "lr" => self.lr = integer(name, v0)?,
            "dr" => self.dr = integer(name, v0)?,
            "dp" => {
                integer(name, v0)?;
            }
            // The file name is not opened: no file access from options.
            "af" => {}
            "lw" => self.lw = in_range(name, number(name, v0)?, 0.0, 1.0)?,
            "av" => {
                let mut c = [0.0; 3];
                for (i, s) in values.iter().enumerate() {
                    c[i] = non_negative(name, number(name, s)?)?;
                }
                self.av = Color::from_array(c);
            }
            "aw" => self.aw = integer(name, v0)?,
            "ab" => self.ab = integer(name, v0)?,
            "aa" => self.aa = in_range(name, number(name, v0)?, 0.0, 1.0)?,
            "ar" => self.ar = integer(name, v0)?,
            "ad" => self.ad = integer(name, v0)?,
            "as" => self.as_ = integer(name, v0)?,
            "pn" => self.pn = integer(name, v0)?,
            "st" => self.st = in_range(name, number(name, v0)?, 0.0, 1.0)?,
            "ss" => self.ss = in_range(name, number(name, v0)?, 0.0, MAX_SPECULAR_SAMPLES)?,
            // rpict reads -ps 0 as 1.
            "ps" => self.ps = integer(name, v0)?.max(1),
            "pt" => self.pt = non_negative(name, number(name, v0)?)?,
            "pj" => self.pj = in_range(name, number(name, v0)?, 0.0, 1.0)?,
            "me" | "ma" => {
                let mut c = [0.0; 3];
                for (i, s) in values.iter().enumerate() {
                    c[i] = non_negative(name, number(name, s)?)?;
                }
                if name == "me" {
                    self.me = Color::from_array(c);
                } else {
                    self.ma = Color::from_array(c);
                }
            }
            "mg" => self.mg = in_range(name, number(name, v0)?, -1.0, 1.0)?,
            "ms" => self.ms = non_negative(name, number(name, v0)?)?,
            _ => unreachable!("option table and match disagree"),
        }
        self.validate()
    }

    /// Applies Radiance options written as one string, as on rpict's
    /// command line (`"-ab 2 -dt 0.01 -av 0 0 0"`); see [`Self::set`].
    pub fn apply_words(&mut self, words: &str) -> Result<()> {
        let mut it = words.split_whitespace().peekable();
        while let Some(w) = it.next() {
            let name = w.strip_prefix('-').ok_or_else(|| {
                Error::Usage(format!("{words:?}: expected an option like -ab, got {w:?}"))
            })?;
            let arity = RADIANCE_OPTIONS
                .iter()
                .find(|o| o.name == split_switch(name).0)
                .map_or(1, |o| o.arity);
            let values: Vec<&str> = (0..arity).filter_map(|_| it.next()).collect();
            self.set(name, &values)?;
        }
        Ok(())
    }

    /// Checks the whole set (also for options built in code): finite values
    /// in range, and no request for a feature that is not implemented yet.
    pub fn validate(&self) -> Result<()> {
        let finite = [
            self.ds, self.dj, self.dt, self.dc, self.lw, self.st, self.ss, self.pj, self.aa,
            self.pt, self.mg, self.ms,
        ];
        if finite.iter().any(|v| !v.is_finite())
            || !self.av.is_finite()
            || !self.me.is_finite()
            || !self.ma.is_finite()
        {
            return Err(Error::Usage(
                "rendering options must be finite numbers".into(),
            ));
        }
        non_negative("ds", self.ds)?;
        in_range("dj", self.dj, 0.0, 1.0)?;
        non_negative("dt", self.dt)?;
        in_range("dc", self.dc, 0.0, 1.0)?;
        in_range("lw", self.lw, 0.0, 1.0)?;
        in_range("st", self.st, 0.0, 1.0)?;
        in_range("ss", self.ss, 0.0, MAX_SPECULAR_SAMPLES)?;
        in_range("pj", self.pj, 0.0, 1.0)?;
        if self.av.min_element() < 0.0 {
            return Err(Error::Usage(
                "-av: ambient value must not be negative".into(),
            ));
        }
        in_range("aa", self.aa, 0.0, 1.0)?;
        in_range("mg", self.mg, -1.0, 1.0)?;
        non_negative("ms", self.ms)?;
        if self.me.min_element() < 0.0 || self.ma.min_element() < 0.0 {
            return Err(Error::Usage(
                "-me, -ma: medium extinction and albedo must not be negative".into(),
            ));
        }
        if self.ab > MAX_AMBIENT_BOUNCES {
            return Err(Error::Usage(format!(
                "-ab {}: at most {MAX_AMBIENT_BOUNCES} ambient bounces are supported (each one multiplies the work)",
                self.ab
            )));
        }
        if self.ab > 0 && self.ad == 0 {
            return Err(Error::Usage(
                "-ad 0: ambient bounces (-ab) need at least one hemisphere division".into(),
            ));
        }
        if self.ad > MAX_AMBIENT_DIVISIONS || self.as_ > MAX_AMBIENT_DIVISIONS {
            return Err(Error::Usage(format!(
                "-ad {} -as {}: at most {MAX_AMBIENT_DIVISIONS} hemisphere rays each",
                self.ad, self.as_
            )));
        }
        if self.pn == 0 || self.pn > MAX_PIXEL_SAMPLES {
            return Err(Error::Usage(format!(
                "-pn {}: pixel samples must be between 1 and {MAX_PIXEL_SAMPLES}",
                self.pn
            )));
        }
        if self.ps == 0 || self.ps as usize > MAX_SIDE {
            return Err(Error::Usage(format!(
                "-ps {}: pixel sample spacing must be between 1 and {}",
                self.ps, MAX_SIDE
            )));
        }
        non_negative("pt", self.pt)?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_radiance_like() {
        let o = RenderOptions::default();
        o.validate().unwrap();
        assert_eq!((o.ds, o.dj, o.dt, o.dc, o.ps), (0.2, 0.0, 0.05, 0.5, 1));
    }

    #[test]
    fn set_parses_and_rejects() {
        let mut o = RenderOptions::default();
        o.set("-ds", &["0.1"]).unwrap();
        o.set("av", &["0.1", "0.2", "0.3"]).unwrap();
        assert_eq!(o.ds, 0.1);
        assert_eq!(o.av, Color::new(0.1, 0.2, 0.3));
        for (n, v) in [
            ("dj", "2"),
            ("dt", "NaN"),
            ("ds", "-1"),
            ("lr", "x"),
            ("ab", "9"),
            ("aa", "2"),
            ("ad", "-1"),
            ("pn", "0"),
            ("pt", "-1"),
            ("zz", "1"),
        ] {
            let e = o.clone().set(n, &[v]).unwrap_err();
            assert_eq!(e.exit_code(), 2, "{n} {v}: {e}");
        }
        o.clone().set("ab", &["2"]).unwrap();
        let e = o.clone().set("ab", &["100"]).unwrap_err().to_string();
        assert!(e.contains("at most"), "{e}");
        let mut z = o.clone();
        z.set("ad", &["0"]).unwrap();
        let e = z.set("ab", &["1"]).unwrap_err().to_string();
        assert!(e.contains("-ad 0"), "{e}");
        o.set("as", &["7"]).unwrap();
        assert_eq!(o.as_, 7);
        assert!(o.set("av", &["1"]).is_err());
    }

    #[test]
    fn apply_words_reads_an_option_string() {
        let mut o = RenderOptions::default();
        o.apply_words("  -dt 0.01 -av 0.1 0.2 0.3\t-ab 2 ").unwrap();
        assert_eq!((o.dt, o.ab), (0.01, 2));
        assert_eq!(o.av, Color::new(0.1, 0.2, 0.3));
        for bad in ["dt 0.1", "-av 1 2", "-dt", "-zz 1", "-dt x"] {
            let e = o.clone().apply_words(bad).unwrap_err();
            assert_eq!(e.exit_code(), 2, "{bad}: {e}");
        }
        o.apply_words("").unwrap();
    }

    /// The suite's settings as rad writes them: `-dp`, `-af` and `-u+` are
    /// accepted (and change nothing), a bad `-dp` is still an error.
    #[test]
    fn rpict_options_without_effect_are_accepted() {
        let mut o = RenderOptions::default();
        o.apply_words("-dp 512 -u+ -dr 1 -ms 0.13 -af glass.amb -u- -ps 6 -pt .08")
            .unwrap();
        let mut plain = RenderOptions::default();
        plain.apply_words("-dr 1 -ms 0.13 -ps 6 -pt .08").unwrap();
        assert_eq!(o, plain);
        for bad in ["-dp x", "-dp -1", "-u 1", "-af"] {
            assert!(o.clone().apply_words(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn switches_and_medium_options() {
        let mut o = RenderOptions::default();
        assert!(o.bv);
        o.apply_words("-bv- -ms 0.27 -me .1 .2 .3 -ma .9 .9 .9 -mg .3 -ab 1")
            .unwrap();
        assert!(!o.bv);
        assert_eq!((o.ms, o.mg, o.ab), (0.27, 0.3, 1));
        assert_eq!(o.me, Color::new(0.1, 0.2, 0.3));
        assert_eq!(o.ma, Color::splat(0.9));
        o.apply_words("-bv+").unwrap();
        assert!(o.bv);
        o.apply_words("-bv").unwrap();
        assert!(!o.bv, "a bare switch toggles, as in rpict");
        for bad in ["-ms -1", "-mg 2", "-me 1 2", "-ds- 1", "-me -1 0 0"] {
            let e = o.clone().apply_words(bad).unwrap_err();
            assert_eq!(e.exit_code(), 2, "{bad}: {e}");
        }
    }

    #[test]
    fn presets_are_valid_and_ordered() {
        let q: Vec<RenderOptions> = QUALITY_PRESETS
            .iter()
            .map(|n| RenderOptions::preset(n).unwrap())
            .collect();
        for o in &q {
            o.validate().unwrap();
        }
        assert!(q[0].ds >= q[1].ds && q[1].ds >= q[2].ds);
        assert!(q[0].pn <= q[1].pn && q[1].pn <= q[2].pn);
        assert_eq!(RenderOptions::preset("fast").unwrap_err().exit_code(), 2);
    }
}
