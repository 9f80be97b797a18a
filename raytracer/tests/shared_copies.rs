//! Copies shared process-wide (`accel::share_copies_in_process`, what an
//! MPI rank turns on): a leaf received over the wire reuses the copies of
//! objects the process holds. In a test binary of its own, since sharing
//! is a process-wide switch.

use hybrid_rt::accel::{share_copies_in_process, LeafObjects, ObjectCopies, Octree, OctreeParams};
use hybrid_rt::geometry::{Shape, Vec3};
use hybrid_rt::scene::Object;

fn polygon(name: String, v: &[[f64; 3]]) -> Object {
    Object {
        name,
        shape: Shape::polygon(v.iter().map(|&p| Vec3::from_array(p)).collect()).unwrap(),
        material: 0,
    }
}

/// A floor listed in many leaves, and small triangles crowding it.
fn scene() -> Vec<Object> {
    let mut out = vec![polygon(
        "floor".into(),
        &[
            [0.0, 0.0, 0.0],
            [10.0, 0.0, 0.0],
            [10.0, 10.0, 0.0],
            [0.0, 10.0, 0.0],
        ],
    )];
    for i in 0..400 {
        let (x, y) = ((i % 20) as f64 * 0.5, (i / 20) as f64 * 0.5);
        out.push(polygon(
            format!("t{i}"),
            &[[x, y, 0.1], [x + 0.4, y, 0.2], [x, y + 0.4, 0.3]],
        ));
    }
    out
}

#[test]
fn received_leaves_share_the_copies_this_process_holds() {
    let objects = scene();
    let tree = Octree::build(&objects, &OctreeParams::default());
    let leaves: Vec<_> = tree
        .leaves()
        .filter(|&l| !tree.leaf_objects(l).is_empty())
        .collect();
    assert!(leaves.len() > 20, "{} leaves", leaves.len());
    let floor_leaves = leaves
        .iter()
        .filter(|&&l| tree.leaf_objects(l).contains(&0))
        .count();
    assert!(floor_leaves > 10, "the floor is in {floor_leaves} leaves");
    // Every other leaf is this processor's.
    let (mine, theirs): (Vec<_>, Vec<_>) = leaves.iter().partition(|&&l| l % 2 == 0);

    // This process's processor: its leaves share one copy per object.
    let mut copies = ObjectCopies::default();
    let resident: Vec<LeafObjects> = mine
        .iter()
        .map(|&l| LeafObjects::copy_from(tree.leaf_objects(l), &objects, &mut copies))
        .collect();
    share_copies_in_process(&copies);

    // Leaves another processor sends (its own copies, serialized).
    let mut sender = ObjectCopies::default();
    let received: Vec<LeafObjects> = theirs
        .iter()
        .map(|&l| {
            let sent = LeafObjects::copy_from(tree.leaf_objects(l), &objects, &mut sender);
            postcard::from_bytes(&postcard::to_allocvec(&sent).unwrap()).unwrap()
        })
        .collect();

    // Every copy of one object in this process is the same copy.
    let mut seen: std::collections::HashMap<u32, *const _> = Default::default();
    let mut shared_with_resident = 0;
    for leaf in resident.iter().chain(&received) {
        for (k, &id) in leaf.ids().iter().enumerate() {
            let held = leaf.own(k).expect("plain surfaces are copied");
            let p: *const _ = held;
            let first = *seen.entry(id).or_insert(p);
            assert_eq!(first, p, "object {id} has two copies in this process");
            if copies.contains_key(&id) && std::ptr::eq(held, &*copies[&id]) {
                shared_with_resident += 1;
            }
        }
    }
    assert!(shared_with_resident > 0);
    // The floor arrives in received leaves and is the resident copy there.
    let floor = |l: &LeafObjects| l.ids().iter().position(|&id| id == 0);
    let arrived: Vec<_> = received
        .iter()
        .filter_map(|l| floor(l).map(|k| l.own(k).unwrap()))
        .collect();
    assert!(!arrived.is_empty() && copies.contains_key(&0));
    assert!(arrived.iter().all(|&h| std::ptr::eq(h, &*copies[&0])));

    // Copies no leaf holds any more are not kept alive: a leaf received
    // afterwards gets a fresh, equal copy.
    drop(resident);
    drop(received);
    drop(copies);
    let l = theirs[0];
    let sent = LeafObjects::copy_from(tree.leaf_objects(l), &objects, &mut ObjectCopies::default());
    let again: LeafObjects = postcard::from_bytes(&postcard::to_allocvec(&sent).unwrap()).unwrap();
    for (k, &id) in again.ids().iter().enumerate() {
        // Equal to the sender's copy of the object (Debug prints every
        // f64 exactly: the vertices or shape, the intersection data, the
        // name and the material), with the source's vertices and bounds.
        // A polygon's copy keeps no name.
        let copy = again.own(k).unwrap();
        assert_eq!(format!("{copy:?}"), format!("{:?}", sent.own(k).unwrap()));
        let o = &objects[id as usize];
        assert_eq!(copy.material(), o.material);
        match copy.name() {
            Some(name) => assert_eq!(name, o.name),
            None => assert!(matches!(o.shape, Shape::Polygon(_))),
        }
        assert_eq!(copy.bounds(), o.shape.bounds());
        if let Shape::Polygon(p) = &o.shape {
            assert_eq!(copy.vertices().as_deref(), Some(&p.vertices[..]));
        }
    }
}
