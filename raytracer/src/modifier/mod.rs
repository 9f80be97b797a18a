//! Radiance's modifiers that are not materials: patterns (colour),
//! textures (normal perturbation) and mixtures, with the data they read
//! (data files, pictures, fonts).
//!
//! A scene's modifiers live in one [`Patterns`] table beside its compiled
//! function program. Every material carries the chain of modifiers that
//! apply to it, in the order Radiance applies them (`rayshade()` walks an
//! object's modifier towards the material, the material's own modifiers
//! follow through `raytexture()`): [`Patterns::apply`] runs a chain for one
//! ray and returns the pattern colour (`r->pcol`) and the normal
//! perturbation (`r->pert`). Materials multiply their colour by the first
//! and perturb their normal by the second. A scene without modifiers never
//! calls into this module (every chain is empty).

pub mod data;
pub mod font;

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

use crate::cal::{self, chan, ExprId, FuncId, Inputs, Program};
use crate::geometry::Color;
use crate::geometry::{Transform, Vec3};
use crate::SourceLoc;

use data::{DataArray, PictureData};
use font::TextLayout;

/// Index into [`Patterns::modifiers`].
pub type ModifierId = u32;

/// One pattern, texture or mixture.
#[derive(Debug)]
pub struct Modifier {
    pub name: String,
    /// Radiance type (`brightfunc`, `texfunc`, ...), for messages.
    pub ptype: String,
    pub kind: Kind,
    /// Pattern space to world (the transform in its string arguments,
    /// followed by any enclosing `xform`); `None` is the identity.
    pub xf: Option<Transform>,
    /// The real arguments (`arg(n)`, `A1`...).
    pub args: Vec<f64>,
    pub loc: SourceLoc,
}

/// How a modifier computes its value.
#[derive(Debug)]
pub enum Kind {
    /// `brightfunc`: the pattern colour is scaled by the expression.
    BrightFunc(ExprId),
    /// `colorfunc`: scaled per channel by three expressions.
    ColorFunc([ExprId; 3]),
    /// `brightdata`: `func(datavalue(coords))`.
    BrightData {
        func: FuncId,
        data: Arc<DataArray>,
        coords: Vec<ExprId>,
    },
    /// `colordata`: one data file and function per channel; a function
    /// of three arguments gets all three data values (`three[i]`), one of
    /// fewer its own channel's (Radiance's `p_cdata`).
    ColorData {
        funcs: [FuncId; 3],
        three: [bool; 3],
        data: [Arc<DataArray>; 3],
        coords: Vec<ExprId>,
    },
    /// `colorpict`: a picture looked up at `(u, v)`, then one function
    /// per channel (of the channel, or of all three when `three[i]`).
    ColorPict {
        funcs: [FuncId; 3],
        three: [bool; 3],
        pict: Picture,
        coords: [ExprId; 2],
    },
    /// `brighttext`/`colortext`: foreground inside the glyphs, background
    /// outside.
    Text {
        layout: Arc<TextLayout>,
        fore: Color,
        back: Color,
    },
    /// `texfunc`: a normal perturbation from three expressions.
    TexFunc([ExprId; 3]),
    /// `texdata`: a normal perturbation from three data files (functions
    /// called as for `colordata`).
    TexData {
        funcs: [FuncId; 3],
        three: [bool; 3],
        data: [Arc<DataArray>; 3],
        coords: Vec<ExprId>,
    },
    /// `prism1`/`prism2` (Radiance's `m_direct.c`): per projection, the
    /// expressions of a coefficient and of a direction (pattern space).
    Redirect(Vec<[ExprId; 4]>),
    /// A mixture of two pattern chains (`mixfunc`, `mixdata`, `mixpict`,
    /// `mixtext` whose sides are not materials). A mixture of materials
    /// is a material ([`crate::scene::Material::Mix`]) whose coefficient
    /// comes from [`Patterns::mix_coefficient`].
    Mix {
        fore: Vec<ModifierId>,
        back: Vec<ModifierId>,
        coef: Mixing,
    },
    /// The orientation vector of an anisotropic material (`plastic2`,
    /// `metal2`, `trans2`, `ashik2`): three expressions `ux uy uz`. Not
    /// in any chain: the material evaluates it per ray through
    /// [`Patterns::direction`].
    Direction([ExprId; 3]),
    /// The functions of a function-defined material (`BRTDfunc`,
    /// `plasfunc`, ..., `transdata`): never applied as a pattern; the
    /// material evaluates them through [`Patterns::material_eval`].
    MaterialFuncs(MaterialFuncs),
}

/// What a function-defined material evaluates (Radiance's `m_brdf.c`).
#[derive(Debug)]
pub enum MaterialFuncs {
    /// `BRTDfunc`: the six specular expressions (reflected red, green,
    /// blue, transmitted red, green, blue), evaluated per ray, and the
    /// three directional functions of the light direction (`None` for
    /// `0`: zero; a channel named like an earlier one has its id).
    Brtd {
        specular: [ExprId; 6],
        directional: [Option<FuncId>; 3],
    },
    /// `plasfunc`, `metfunc`, `transfunc`: the BRDF as a function of the
    /// light direction and solid angle.
    Func(FuncId),
    /// `plasdata`, `metdata`, `transdata`: the data file's value at the
    /// coordinates the coordinate functions give for the light direction,
    /// passed through `func` (with the direction and solid angle after it).
    Data {
        func: FuncId,
        data: Arc<DataArray>,
        coords: Vec<FuncId>,
    },
}

/// A picture a pattern reads, or why it could not be read. Radiance reads
/// a picture when a ray first needs it, so a missing picture that no ray
/// reaches does not stop a render; one that is reached counts as a failed
/// evaluation (the pattern leaves the ray unchanged) in the report.
pub type Picture = Result<Arc<PictureData>, Arc<str>>;

/// Where a mixture's coefficient comes from.
#[derive(Debug)]
pub enum Mixing {
    Func(ExprId),
    Data {
        func: FuncId,
        data: Arc<DataArray>,
        coords: Vec<ExprId>,
    },
    Pict {
        func: FuncId,
        pict: Picture,
        coords: [ExprId; 2],
    },
    /// 1 inside the glyphs (foreground), 0 outside.
    Text(Arc<TextLayout>),
}

/// The ray at a surface, in world space: what the ray variables are made of.
#[derive(Debug, Clone, Copy)]
pub struct RayVars {
    /// Unit ray direction.
    pub dir: Vec3,
    /// Unit surface normal as the surface defines it (not turned to the ray).
    pub normal: Vec3,
    pub point: Vec3,
    /// Distance along the ray (`T`).
    pub t: f64,
    /// Shadow-ray distance (`Ts`): 0 for rays other than shadow rays.
    pub ts: f64,
    /// Local surface coordinates of meshes (`Lu`, `Lv`).
    pub uv: [f64; 2],
}

/// What a chain of patterns and textures did to a ray: `r->pcol` and
/// `r->pert`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Applied {
    pub color: Color,
    pub pert: Vec3,
}

impl Applied {
    pub const NONE: Applied = Applied {
        color: Color::ONE,
        pert: Vec3::ZERO,
    };

    /// True when the perturbation is large enough to change the normal
    /// (Radiance's `DOT(r->pert, r->pert) > FTINY*FTINY`).
    pub fn perturbs(&self) -> bool {
        self.pert.length_squared() > 1e-12
    }
}

/// Deepest nesting of mixtures followed in one evaluation (a mixture
/// whose side leads back to itself is refused when loading; this bounds
/// what remains).
const MAX_MIX_DEPTH: usize = 32;

/// Evaluation failures of a render: counted, the first kept for the report.
#[derive(Debug, Default)]
pub struct EvalFailures {
    nan: AtomicU64,
    errors: AtomicU64,
    first: Mutex<Option<String>>,
}

impl EvalFailures {
    fn record_nan(&self, m: &Modifier) {
        if self.nan.fetch_add(1, Ordering::Relaxed) == 0 {
            self.keep(format!(
                "{}: {} '{}' evaluated to NaN (treated as 0)",
                m.loc, m.ptype, m.name
            ));
        }
    }

    /// An evaluation that could not finish (an error, or a missing picture).
    fn record_error(&self, m: &Modifier, why: &dyn std::fmt::Display) {
        if self.errors.fetch_add(1, Ordering::Relaxed) == 0 {
            self.keep(format!("{}: {} '{}': {why}", m.loc, m.ptype, m.name));
        }
    }

    fn keep(&self, msg: String) {
        if let Ok(mut f) = self.first.lock() {
            if f.is_none() {
                *f = Some(msg);
            }
        }
    }

    /// NaN results so far.
    pub fn nans(&self) -> u64 {
        self.nan.load(Ordering::Relaxed)
    }

    /// Evaluations that failed (recursion too deep) so far.
    pub fn errors(&self) -> u64 {
        self.errors.load(Ordering::Relaxed)
    }

    /// The first failure, as a message naming the modifier.
    pub fn first(&self) -> Option<String> {
        self.first.lock().ok().and_then(|f| f.clone())
    }
}

/// A scene's modifiers and the function program they evaluate.
#[derive(Debug)]
pub struct Patterns {
    pub modifiers: Vec<Modifier>,
    pub program: Program,
    pub failures: EvalFailures,
}

impl Default for Patterns {
    fn default() -> Self {
        Self {
            modifiers: Vec::new(),
            program: Program::empty(),
            failures: EvalFailures::default(),
        }
    }
}

/// One modifier's view of a ray: its inputs in pattern space.
struct Eval<'a> {
    p: &'a Patterns,
    m: &'a Modifier,
    inputs: Inputs<'a>,
}

impl<'a> Eval<'a> {
    fn new(p: &'a Patterns, m: &'a Modifier, r: &RayVars, extra: &Applied) -> Self {
        let mut v = [0.0; cal::N_INPUTS];
        let (d, n, pt, t, ts, s, o, i, j, k) = match &m.xf {
            None => (
                r.dir,
                r.normal,
                r.point,
                r.t,
                r.ts,
                1.0,
                Vec3::ZERO,
                Vec3::X,
                Vec3::Y,
                Vec3::Z,
            ),
            Some(xf) => {
                // World to pattern space: directions rotated back and
                // renormalised, points mapped, lengths scaled.
                let inv = 1.0 / xf.scale;
                let unit = |w: Vec3| xf.inv_vector(w) * xf.scale;
                let m = xf.to_object;
                (
                    unit(r.dir),
                    unit(r.normal),
                    xf.inv_point(r.point),
                    r.t * inv,
                    r.ts * inv,
                    inv,
                    m.w_axis.truncate(),
                    m.x_axis.truncate() * xf.scale,
                    m.y_axis.truncate() * xf.scale,
                    m.z_axis.truncate() * xf.scale,
                )
            }
        };
        let put = |v: &mut [f64; cal::N_INPUTS], at: usize, w: Vec3| {
            v[at] = w.x;
            v[at + 1] = w.y;
            v[at + 2] = w.z;
        };
        put(&mut v, chan::DX, d);
        put(&mut v, chan::NX, n);
        put(&mut v, chan::PX, pt);
        v[chan::T] = t;
        v[chan::RDOT] = (-r.dir.dot(r.normal)).clamp(-1.0, 1.0);
        v[chan::S] = s;
        put(&mut v, chan::TX, o);
        put(&mut v, chan::IX, i);
        put(&mut v, chan::JX, j);
        put(&mut v, chan::KX, k);
        v[chan::TS] = ts;
        v[chan::LU] = r.uv[0];
        v[chan::LV] = r.uv[1];
        // Perturbed normal and colour so far (Radiance sets these for
        // *func materials; harmless for patterns).
        let pn = (r.normal + extra.pert).normalize_or(r.normal);
        put(&mut v, chan::NXP, pn);
        v[chan::RDOTP] = -r.dir.dot(pn);
        put(&mut v, chan::CRP, extra.color);
        Self {
            p,
            m,
            inputs: Inputs {
                values: v,
                args: &m.args,
            },
        }
    }

    /// One value; NaN and failures count and read as 0 (Radiance's
    /// "compute error" leaves the ray unpatterned: see [`Self::ok`]).
    fn expr(&self, e: ExprId) -> Option<f64> {
        self.checked(self.p.program.eval(e, &self.inputs))
    }

    fn call(&self, f: FuncId, args: &[f64]) -> Option<f64> {
        self.checked(self.p.program.call(f, args, &self.inputs))
    }

    fn checked(&self, r: Result<f64, cal::EvalError>) -> Option<f64> {
        match r {
            Ok(v) if v.is_nan() => {
                self.p.failures.record_nan(self.m);
                None
            }
            Ok(v) => Some(v),
            Err(e) => {
                self.p.failures.record_error(self.m, &e);
                None
            }
        }
    }

    fn coords(&self, coords: &[ExprId]) -> Option<smallvec_coords::Coords> {
        let mut c = smallvec_coords::Coords::default();
        for &e in coords {
            c.push(self.expr(e)?);
        }
        Some(c)
    }

    /// The picture coordinates: Radiance evaluates `u` then `v` and looks
    /// the picture up `v`-major.
    fn uv(&self, coords: &[ExprId; 2]) -> Option<(f64, f64)> {
        Some((self.expr(coords[0])?, self.expr(coords[1])?))
    }

    /// The picture's colour at (u, v), or a counted failure if it is missing.
    fn picture(&self, pict: &Picture, u: f64, v: f64) -> Option<[f64; 3]> {
        match pict {
            Ok(p) => Some(p.value(u, v)),
            Err(why) => {
                self.p.failures.record_error(self.m, why);
                None
            }
        }
    }

    /// A world direction in pattern space, unit length (Radiance's
    /// `multv3(v, w, funcxf.xfm)` divided by `funcxf.sca`).
    fn dir(&self, w: Vec3) -> Vec3 {
        match &self.m.xf {
            None => w,
            Some(xf) => xf.inv_vector(w) * xf.scale,
        }
    }

    /// A displacement in pattern space back to world space (with the
    /// transform's scale, as Radiance's `multv3` with the forward matrix).
    fn to_world(&self, d: Vec3) -> Vec3 {
        match &self.m.xf {
            None => d,
            Some(xf) => xf.vector(d),
        }
    }

    /// A normal perturbation in pattern space to world space: turned by
    /// the transform but not scaled (Radiance's `t_func()` and `t_data()`
    /// divide `multv3`'s result by the transform's scale), so a scaled
    /// object keeps its normals' perturbation.
    fn pert_to_world(&self, d: Vec3) -> Vec3 {
        match &self.m.xf {
            None => d,
            Some(xf) => xf.vector(d) / xf.scale,
        }
    }
}

/// A few data coordinates without allocating.
mod smallvec_coords {
    /// Data files of more dimensions than this are refused when loading.
    pub const MAX: usize = 8;

    #[derive(Default)]
    pub struct Coords {
        v: [f64; MAX],
        n: usize,
    }

    impl Coords {
        pub fn push(&mut self, x: f64) {
            if self.n < MAX {
                self.v[self.n] = x;
                self.n += 1;
            }
        }
        pub fn as_slice(&self) -> &[f64] {
            &self.v[..self.n]
        }
    }
}

pub use smallvec_coords::MAX as MAX_DATA_DIMS;

impl Patterns {
    /// True when the scene has no modifiers at all.
    pub fn is_empty(&self) -> bool {
        self.modifiers.is_empty()
    }

    /// Runs `chain` for one ray, starting from `acc`.
    pub fn apply(&self, chain: &[ModifierId], r: &RayVars, acc: &mut Applied) {
        self.apply_depth(chain, r, acc, 0);
    }

    fn apply_depth(&self, chain: &[ModifierId], r: &RayVars, acc: &mut Applied, depth: usize) {
        for &id in chain {
            let Some(m) = self.modifiers.get(id as usize) else {
                continue;
            };
            self.apply_one(m, r, acc, depth);
        }
    }

    fn apply_one(&self, m: &Modifier, r: &RayVars, acc: &mut Applied, depth: usize) {
        let ev = Eval::new(self, m, r, acc);
        match &m.kind {
            Kind::BrightFunc(e) => {
                if let Some(b) = ev.expr(*e) {
                    acc.color *= b;
                }
            }
            Kind::ColorFunc(es) => {
                if let (Some(r), Some(g), Some(b)) =
                    (ev.expr(es[0]), ev.expr(es[1]), ev.expr(es[2]))
                {
                    acc.color *= Color::new(r, g, b);
                }
            }
            Kind::BrightData { func, data, coords } => {
                let Some(x) = ev.coords(coords) else { return };
                let v = data.value(x.as_slice());
                if let Some(b) = ev.call(*func, &[v]) {
                    acc.color *= b;
                }
            }
            Kind::ColorData {
                funcs,
                three,
                data,
                coords,
            } => {
                let Some(c) = Self::data_triple(&ev, funcs, three, data, coords) else {
                    return;
                };
                acc.color *= c;
            }
            Kind::ColorPict {
                funcs,
                three,
                pict,
                coords,
            } => {
                let Some((u, v)) = ev.uv(coords) else { return };
                let Some(col) = ev.picture(pict, u, v) else {
                    return;
                };
                let mut c = Color::ZERO;
                for i in 0..3 {
                    let r = if three[i] {
                        ev.call(funcs[i], &col)
                    } else {
                        ev.call(funcs[i], &col[i..i + 1])
                    };
                    let Some(b) = r else { return };
                    c[i] = b;
                }
                acc.color *= c;
            }
            Kind::Text { layout, fore, back } => {
                let p = match &m.xf {
                    None => r.point,
                    Some(xf) => xf.inv_point(r.point),
                };
                acc.color *= if layout.inside(p) { *fore } else { *back };
            }
            Kind::TexFunc(es) => {
                if let (Some(x), Some(y), Some(z)) =
                    (ev.expr(es[0]), ev.expr(es[1]), ev.expr(es[2]))
                {
                    acc.pert += ev.pert_to_world(Vec3::new(x, y, z));
                }
            }
            Kind::TexData {
                funcs,
                three,
                data,
                coords,
            } => {
                let Some(d) = Self::data_triple(&ev, funcs, three, data, coords) else {
                    return;
                };
                acc.pert += ev.pert_to_world(d);
            }
            Kind::Redirect(_) => {}
            Kind::Mix { fore, back, coef } => {
                if depth >= MAX_MIX_DEPTH {
                    return;
                }
                let Some(c) = self.coefficient(&ev, coef, r) else {
                    return;
                };
                // raymixture(): both sides start from the current state;
                // the results are blended.
                let mut f = *acc;
                let mut b = *acc;
                if c > 1e-6 {
                    self.apply_depth(fore, r, &mut f, depth + 1);
                }
                if c < 1.0 - 1e-6 {
                    self.apply_depth(back, r, &mut b, depth + 1);
                }
                acc.pert = f.pert * c + b.pert * (1.0 - c);
                acc.color = f.color * c + b.color * (1.0 - c);
            }
            // A material's orientation vector changes nothing here.
            Kind::Direction(_) => {}
            Kind::MaterialFuncs(_) => {}
        }
    }

    /// Three data values at the coordinates, each passed through its
    /// channel's function.
    fn data_triple(
        ev: &Eval,
        funcs: &[FuncId; 3],
        three: &[bool; 3],
        data: &[Arc<DataArray>; 3],
        coords: &[ExprId],
    ) -> Option<Vec3> {
        let x = ev.coords(coords)?;
        let v = [
            data[0].value(x.as_slice()),
            data[1].value(x.as_slice()),
            data[2].value(x.as_slice()),
        ];
        let mut out = Vec3::ZERO;
        for i in 0..3 {
            out[i] = if three[i] {
                ev.call(funcs[i], &v)?
            } else {
                ev.call(funcs[i], &v[i..i + 1])?
            };
        }
        Some(out)
    }

    fn coefficient(&self, ev: &Eval, coef: &Mixing, r: &RayVars) -> Option<f64> {
        let c = match coef {
            Mixing::Func(e) => ev.expr(*e)?,
            Mixing::Data { func, data, coords } => {
                let x = ev.coords(coords)?;
                let v = data.value(x.as_slice());
                ev.call(*func, &[v])?
            }
            Mixing::Pict { func, pict, coords } => {
                let (u, v) = ev.uv(coords)?;
                let col = ev.picture(pict, u, v)?;
                ev.call(*func, &col)?
            }
            Mixing::Text(layout) => {
                let p = match &ev.m.xf {
                    None => r.point,
                    Some(xf) => xf.inv_point(r.point),
                };
                if layout.inside(p) {
                    1.0
                } else {
                    0.0
                }
            }
        };
        Some(c.clamp(0.0, 1.0))
    }

    /// Projection `k` of the redirecting modifier `id` (`prism1`,
    /// `prism2`) for one ray: its coefficient and unit world direction;
    /// `None` when it could not be computed (counted as a failure).
    pub fn redirect(&self, id: ModifierId, k: usize, r: &RayVars) -> Option<(f64, Vec3)> {
        let m = self.modifiers.get(id as usize)?;
        let Kind::Redirect(projections) = &m.kind else {
            return None;
        };
        let e = projections.get(k)?;
        let ev = Eval::new(self, m, r, &Applied::NONE);
        let coef = ev.expr(e[0])?;
        let d = Vec3::new(ev.expr(e[1])?, ev.expr(e[2])?, ev.expr(e[3])?);
        let w = ev.to_world(d);
        let len = w.length();
        (len > 0.0 && len.is_finite() && coef.is_finite()).then(|| (coef, w / len))
    }

    /// The foreground fraction of the mixture modifier `id` for one ray (a
    /// mixture of materials): in [0, 1]; `None` when it could not be
    /// computed (NaN or failure, counted), which Radiance treats as "no
    /// mixture" (the ray passes through).
    pub fn mix_coefficient(&self, id: ModifierId, r: &RayVars) -> Option<f64> {
        let m = self.modifiers.get(id as usize)?;
        let Kind::Mix { coef, .. } = &m.kind else {
            return None;
        };
        let ev = Eval::new(self, m, r, &Applied::NONE);
        self.coefficient(&ev, coef, r)
    }

    /// The orientation vector of an anisotropic material for one ray
    /// (Radiance's `getacoords()`): the modifier `id`'s three expressions
    /// in its space, turned to world space by its transform (with the
    /// transform's scale, as `multv3`). `acc` is what the material's
    /// patterns did (`NxP`, `CrP`...). `None` when an expression failed
    /// or gave NaN (counted, as Radiance's "compute error"): the caller
    /// falls back as for a zero vector.
    pub fn direction(&self, id: ModifierId, r: &RayVars, acc: &Applied) -> Option<Vec3> {
        let m = self.modifiers.get(id as usize)?;
        let Kind::Direction(es) = &m.kind else {
            return None;
        };
        let ev = Eval::new(self, m, r, acc);
        let d = Vec3::new(ev.expr(es[0])?, ev.expr(es[1])?, ev.expr(es[2])?);
        if !d.is_finite() {
            return None;
        }
        Some(ev.to_world(d))
    }

    /// Records (once, counted with the failed evaluations) that the
    /// orientation vector of modifier `id` gave no direction in the
    /// surface for a ray: Radiance's "illegal orientation vector"
    /// warning; the material fell back to an isotropic mean roughness.
    pub fn report_bad_direction(&self, id: ModifierId) {
        if let Some(m) = self.modifiers.get(id as usize) {
            self.failures.record_error(
                m,
                &"illegal orientation vector (zero, or along the surface normal); rendered with the mean roughness",
            );
        }
    }
}

/// What a function-defined material sets besides the ray's variables
/// (Radiance's `setbrdfunc`): the perturbed normal turned towards the ray
/// (`NxP`...), its cosine with the reversed ray (`RdotP`) and the
/// material colour with its patterns (`CrP`...).
#[derive(Debug, Clone, Copy)]
pub struct MaterialVars {
    pub pnorm: Vec3,
    pub pdot: f64,
    pub color: Color,
}

/// A function-defined material's view of one ray: evaluations that fail
/// or give NaN count as the pattern failures do, and read as `None`.
pub struct MaterialEval<'a>(Eval<'a>);

impl MaterialEval<'_> {
    /// The material's functions.
    pub fn funcs(&self) -> Option<&MaterialFuncs> {
        match &self.0.m.kind {
            Kind::MaterialFuncs(f) => Some(f),
            _ => None,
        }
    }

    pub fn expr(&self, e: ExprId) -> Option<f64> {
        self.0.expr(e)
    }

    pub fn call(&self, f: FuncId, args: &[f64]) -> Option<f64> {
        self.0.call(f, args)
    }

    /// A world direction in the material's function space (unit length).
    pub fn dir(&self, w: Vec3) -> Vec3 {
        self.0.dir(w)
    }
}

impl Patterns {
    /// The evaluation context of the function-defined material whose
    /// functions are modifier `id`, for the ray `r` (its normal as the
    /// material presents it to the functions) with the material's own
    /// variables `v`.
    pub fn material_eval(
        &self,
        id: ModifierId,
        r: &RayVars,
        v: &MaterialVars,
    ) -> Option<MaterialEval<'_>> {
        let m = self.modifiers.get(id as usize)?;
        let mut ev = Eval::new(self, m, r, &Applied::NONE);
        let pn = ev.dir(v.pnorm);
        ev.inputs.values[chan::NXP] = pn.x;
        ev.inputs.values[chan::NYP] = pn.y;
        ev.inputs.values[chan::NZP] = pn.z;
        ev.inputs.values[chan::RDOTP] = v.pdot.clamp(-1.0, 1.0);
        ev.inputs.values[chan::CRP] = v.color.x;
        ev.inputs.values[chan::CGP] = v.color.y;
        ev.inputs.values[chan::CBP] = v.color.z;
        Some(MaterialEval(ev))
    }
}
