//! Which scene and view a subcommand renders: built-in scene names, the
//! view file beside a scene, view options and Radiance's default view.

use std::path::{Path, PathBuf};

use super::common::usage;
use crate::scene::View;
use crate::{Error, Result, SourceLoc};

/// Where the built-in scenes live: `examples/scenes` under the current
/// directory or the workspace this binary was built from.
fn builtin_dir() -> Vec<PathBuf> {
    vec![
        PathBuf::from("examples/scenes"),
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/scenes"),
    ]
}

/// The view file beside a scene file: `SCENE.vf` for `SCENE.rad`.
pub(super) fn view_file_beside(scene: &Path) -> PathBuf {
    scene.with_extension("vf")
}

/// A built-in scene name (cornell, studio, conference) or a scene file, with
/// its view file (`view_file`, else the `.vf` next to the scene).
pub(super) fn resolve_scene_view(scene: &str, view_file: Option<&Path>) -> Result<(PathBuf, View)> {
    let (scene_path, default_vf) = if matches!(scene, "cornell" | "studio" | "conference") {
        let found = builtin_dir()
            .into_iter()
            .map(|d| d.join(format!("{scene}.rad")))
            .find(|p| p.is_file());
        let Some(p) = found else {
            return Err(Error::Other(format!(
                "built-in scene {scene:?} not found (looked for examples/scenes/{scene}.rad)"
            )));
        };
        let vf = view_file_beside(&p);
        (p, vf)
    } else {
        let p = PathBuf::from(scene);
        let vf = view_file_beside(&p);
        (p, vf)
    };
    if !scene_path.is_file() {
        return Err(Error::io(
            &scene_path,
            std::io::Error::from(std::io::ErrorKind::NotFound),
        ));
    }
    let vf = view_file.map(Path::to_path_buf).unwrap_or(default_vf);
    let view = build_view(Some(&vf), &[], &[])?;
    Ok((scene_path, view))
}

/// The view from `--view-file`, then `--view`, then Radiance-style words.
pub(super) fn build_view(
    file: Option<&Path>,
    options: &[String],
    words: &[String],
) -> Result<View> {
    let mut view = match file {
        Some(f) => View::from_file(f)?,
        None => View::default(),
    };
    let mut given = file.is_some();
    let mut apply = |text: &str, what: &str| -> Result<()> {
        let loc = SourceLoc::new(what, 1);
        view.apply_options(text, &loc)?;
        view.validate().map_err(|r| Error::parse(loc, r))
    };
    for o in options {
        apply(o, "<--view>")?;
        given = true;
    }
    if !words.is_empty() {
        apply(&words.join(" "), "<command line>")?;
        given = true;
    }
    if !given {
        return Err(usage(
            "no view given: use --view-file FILE or --view \"-vtv -vp ... -vd ...\"",
        ));
    }
    Ok(view)
}

/// The view when none is given (no `-vf`, `--view` or `-v` option): the
/// first view stored in a compiled scene, else `SCENE.vf` beside the first scene file if there is one (as `bench` and
/// `sweep` find it), else for an OBJ scene none yet (it is framed once
/// loaded, see [`View::framing`]), else Radiance's default view.
pub(super) fn default_view(scenes: &[PathBuf]) -> Result<Option<View>> {
    let Some(first) = scenes.first() else {
        return Ok(Some(View::default()));
    };
    if scenes.len() == 1 && crate::compiled::is_compiled(first) {
        let c = crate::compiled::CompiledScene::open(first)?;
        if let Some(text) = c.replicated().views.first() {
            let where_ = format!("{} (its stored view)", first.display());
            let view = View::from_file_text(text, &where_)?;
            eprintln!("view: {where_}");
            return Ok(Some(view));
        }
    }
    let vf = view_file_beside(first);
    if vf.is_file() {
        let view = build_view(Some(&vf), &[], &[])?;
        eprintln!("view: {} (beside the scene)", vf.display());
        return Ok(Some(view));
    }
    let obj = first
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("obj"));
    if obj {
        return Ok(None);
    }
    let view = View::default();
    eprintln!(
        "view: Radiance's default ({}), no {} beside the scene",
        view.to_options(),
        vf.display()
    );
    Ok(Some(view))
}
