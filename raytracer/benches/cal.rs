//! Evaluation cost of compiled `.cal` expressions (ns per evaluation):
//! patterns from the Radiance test scenes and a light-source distribution
//! call chain like source.cal's `flatcorr` over `src_phi4`.

use std::path::PathBuf;

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use hybrid_rt::cal::{chan, Inputs, Library, N_INPUTS};
use hybrid_rt::SourceLoc;

/// The definitions of source.cal this bench uses (the file itself is read
/// from the shared scenes when they are there).
const SOURCE_CAL: &str = "
corr(v) = if(AC-.5, A1*v, v);
flatcorr(v) = corr(v) / Rdot;
src_theta = Acos(Dz) / DEGREE;
src_phi = mod(Atan2(-Dy, -Dx) / DEGREE, 360);
src_phi4 = tri(src_phi, 90);
";

fn source_cal_dir() -> PathBuf {
    let shared = PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../shared/scenes/radiance-tests/lib"
    ));
    if shared.join("source.cal").is_file() {
        return shared;
    }
    let d = std::env::temp_dir().join(format!("hybrid-rt-cal-bench-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    std::fs::write(d.join("source.cal"), SOURCE_CAL).unwrap();
    d
}

/// Ray states along a curve, made before timing so that only evaluation is
/// measured.
fn ray_states() -> Vec<[f64; N_INPUTS]> {
    (0..256)
        .map(|k| {
            let mut v = [0.0; N_INPUTS];
            let t = k as f64 * 0.0137;
            v[chan::DX] = t.sin() * 0.6;
            v[chan::DY] = t.cos() * 0.6;
            v[chan::DZ] = -0.8;
            v[chan::NZ] = 1.0;
            v[chan::PX] = 1.3 + t;
            v[chan::PY] = 0.7 - t;
            v[chan::PZ] = 0.25 * t;
            v[chan::RDOT] = 0.8;
            v
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let loc = SourceLoc::new("bench.rad", 1);
    let mut lib = Library::new(Vec::new()).unwrap();
    let g = lib.global();
    let exprs = [
        ("noisepat", "1 - .35*(1+fnoise3(3*Px,3*Py,3*Pz))"),
        ("cfpat_x", ".5+.2*noise3x(5*Px,5*Py,5*Pz)"),
        ("dot_D_N", "dot(D, N)"),
        ("turbulence", "turbulence(Px, Py, Pz, .125)"),
        ("U_V", "U*V"),
    ];
    let ids: Vec<_> = exprs
        .iter()
        .map(|(n, e)| (*n, lib.expr(g, e, &loc).unwrap()))
        .collect();
    let src = lib
        .load_file("source.cal", &source_cal_dir(), &loc)
        .unwrap();
    let phi = lib.expr(src, "src_phi4", &loc).unwrap();
    let flatcorr = lib.function(src, "flatcorr", 1, &loc).unwrap();
    let chain = lib.expr(src, "flatcorr(src_phi4)", &loc).unwrap();
    let p = lib.finish().unwrap();

    let args = [1.0];
    let states = ray_states();
    let inputs = |args, k: usize| Inputs {
        values: states[k % states.len()],
        args,
    };
    let mut group = c.benchmark_group("cal");
    for (name, id) in ids {
        let mut k = 0usize;
        group.bench_function(name, |b| {
            b.iter(|| {
                k = k.wrapping_add(1);
                p.eval(black_box(id), &inputs(&args[..], k)).unwrap()
            })
        });
    }
    let mut k = 0usize;
    group.bench_function("source_src_phi4_then_flatcorr", |b| {
        b.iter(|| {
            k = k.wrapping_add(1);
            let inp = inputs(&args[..], k);
            let v = p.eval(phi, &inp).unwrap();
            p.call(flatcorr, &[black_box(v)], &inp).unwrap()
        })
    });
    let mut k = 0usize;
    group.bench_function("source_flatcorr_src_phi4_expr", |b| {
        b.iter(|| {
            k = k.wrapping_add(1);
            p.eval(black_box(chain), &inputs(&args[..], k)).unwrap()
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
