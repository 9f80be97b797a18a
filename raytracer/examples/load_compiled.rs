//! Times loading a scene from its Radiance text against loading its
//! compiled form (`hybrid-rt compile`), alternating the two so that both
//! see the same machine:
//!
//! ```text
//! cargo run --release -p hybrid-rt --example load_compiled -- SCENE.rad SCENE.hrtc [RUNS]
//! ```
//!
//! Prints each file's size, the median seconds of each load over RUNS
//! (default 3) and their ratio, and how long the compiled load takes to
//! open the file (header, replicated part, index) and to read and decode
//! every cell (the rest is building the scene's shapes). Both loads must make the same scene
//! (objects, materials and lights compared).

use std::path::PathBuf;

// The allocator of the `hybrid-rt` binary, so the loads cost what they
// cost there.
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 2 {
        eprintln!("usage: load_compiled SCENE.rad SCENE.hrtc [RUNS]");
        std::process::exit(2);
    }
    let text = PathBuf::from(&args[0]);
    let compiled = PathBuf::from(&args[1]);
    let runs: usize = args.get(2).and_then(|r| r.parse().ok()).unwrap_or(3).max(1);
    let mut t_text = Vec::new();
    let mut t_comp = Vec::new();
    let mut t_open = Vec::new();
    let mut t_read = Vec::new();
    let mut check = None;
    for _ in 0..runs {
        let t = Instant::now();
        let a = hybrid_rt::scene::load(std::slice::from_ref(&text)).unwrap_or_else(|e| fail(e));
        t_text.push(t.elapsed().as_secs_f64());
        let t = Instant::now();
        let b = hybrid_rt::compiled::load_scene(&compiled).unwrap_or_else(|e| fail(e));
        t_comp.push(t.elapsed().as_secs_f64());
        let t = Instant::now();
        let c = hybrid_rt::compiled::CompiledScene::open(&compiled).unwrap_or_else(|e| fail(e));
        t_open.push(t.elapsed().as_secs_f64());
        let surfaces = c.read_surfaces().unwrap_or_else(|e| fail(e));
        t_read.push(t.elapsed().as_secs_f64());
        drop(surfaces);
        if check.is_none() {
            let same = a.objects.len() == b.objects.len()
                && format!("{:?}", a.objects) == format!("{:?}", b.objects)
                && a.materials == b.materials
                && a.lights == b.lights;
            check = Some((same, a.objects.len()));
        }
    }
    let (same, objects) = check.expect("one run");
    if !same {
        eprintln!("the two loads made different scenes");
        std::process::exit(1);
    }
    let size = |p: &PathBuf| std::fs::metadata(p).map(|m| m.len()).unwrap_or(0);
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let (a, b) = (median(&mut t_text), median(&mut t_comp));
    println!("objects: {objects}");
    println!(
        "text:     {:>12} bytes, load {a:.3} s (median of {runs})",
        size(&text)
    );
    println!(
        "compiled: {:>12} bytes, load {b:.3} s (median of {runs})",
        size(&compiled)
    );
    println!("text / compiled: {:.2}x", a / b);
    println!(
        "of the compiled load: header, replicated part and index {:.3} s; with every cell read and decoded {:.3} s; the rest builds the scene",
        median(&mut t_open),
        median(&mut t_read)
    );
}

fn fail(e: hybrid_rt::Error) -> ! {
    eprintln!("error: {e}");
    std::process::exit(1);
}
