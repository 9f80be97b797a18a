//! Table 1: scene and octree statistics.

use serde_json::json;

use super::harness::Ctx;
use crate::accel::OctreeParams;
use crate::render::Renderer;
use crate::report::table::Table;
use crate::Result;

pub(super) fn table1(cx: &mut Ctx) -> Result<()> {
    let s = cx.s;
    let renderer = Renderer::shared(s.scene.clone(), s.options.clone(), &OctreeParams::default())?;
    let st = &s.scene.stats;
    let os = renderer.octree().stats().clone();
    // The paper's Table 1 for its two models.
    let paper = match s.name.as_str() {
        "studio" => Some(["5311", "4606", "-", "705", "25733", "3676", "51925"]),
        "conference" => Some(["3951", "-", "6151", "-", "8667", "-", "29569"]),
        _ => None,
    };
    let ours = [
        (st.objects + st.materials).to_string(),
        st.primitives.to_string(),
        st.instances.to_string(),
        st.materials.to_string(),
        os.leaf_nodes.to_string(),
        os.internal_nodes.to_string(),
        os.object_refs.to_string(),
    ];
    let rows = [
        "objects (top-level objects + materials, the paper's count)",
        "primitives",
        "instances",
        "materials, patterns, textures",
        "octree leaves",
        "octree internal nodes",
        "object references",
    ];
    let mut t = Table::new(["", "ours", "paper"]);
    for (i, r) in rows.iter().enumerate() {
        t.row([
            r.to_string(),
            ours[i].clone(),
            paper.map_or("-".to_string(), |p| p[i].to_string()),
        ]);
    }
    let json = json!({
        "scene": s.name,
        "objects": st.objects, "primitives": st.primitives, "instances": st.instances,
        "materials": st.materials, "leaves": os.leaf_nodes, "internal_nodes": os.internal_nodes,
        "object_refs": os.object_refs, "max_depth": os.max_depth,
    });
    cx.finish(
        "table1",
        "Table 1: scene and octree statistics",
        "The paper counts materials, patterns and textures among its objects.",
        &[t],
        json,
    )
}
