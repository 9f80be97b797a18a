//! Tests of the assembly of pixels from ray-tree records.

use super::*;
use hybrid_sched::ByteSize;

fn c(v: f64) -> Color {
    Color::splat(v)
}

#[test]
fn out_of_order_results_give_the_in_order_value() {
    // root: base 0.1, children [Trace(0.5), Shadow]; child 0: base 0.2,
    // children [Shadow]; attenuation at the root.
    let root = RtResult {
        key: NodeKey::root(7),
        record: Record::Shaded {
            base: c(0.1),
            children: vec![Child::Trace(c(0.5)), Child::Shadow],
            attenuation: Some((c(0.9), Color::ZERO)),
        },
    };
    let k0 = NodeKey::root(7).child(0);
    let child = RtResult {
        key: k0.clone(),
        record: Record::Shaded {
            base: c(0.2),
            children: vec![Child::Shadow],
            attenuation: None,
        },
    };
    let grandchild = RtResult {
        key: k0.child(0),
        record: Record::Value(c(0.3)),
    };
    let shadow = RtResult {
        key: NodeKey::root(7).child(1),
        record: Record::Value(c(0.4)),
    };
    let expected = (c(0.1) + c(0.5) * (c(0.2) + c(0.3)) + c(0.4)) * c(0.9);
    let all = [root, child, grandchild, shadow];
    // Every arrival order.
    let mut orders = vec![vec![0, 1, 2, 3]];
    for _ in 0..23 {
        let mut next = orders.last().unwrap().clone();
        // next permutation
        let mut i = 3;
        while i > 0 && next[i - 1] >= next[i] {
            i -= 1;
        }
        if i == 0 {
            break;
        }
        let mut j = 3;
        while next[j] <= next[i - 1] {
            j -= 1;
        }
        next.swap(i - 1, j);
        next[i..].reverse();
        orders.push(next);
    }
    assert_eq!(orders.len(), 24);
    for order in orders {
        let mut t = PixelTrees::default();
        for &i in &order {
            t.merge(all[i].clone());
        }
        assert_eq!(t.pixels, vec![(7, expected)], "order {order:?}");
        assert_eq!(t.pending(), 0);
    }
}

/// A point with a reflection and a shadow bundle, a hemisphere of
/// three strata (one sample not finite) and a hemisphere not sampled:
/// the hemispheres' terms come before the requests', as the sequential
/// renderer adds them, in every order the results arrive in.
#[test]
fn hemispheres_are_added_first_whatever_the_order() {
    let root = NodeKey::root(3);
    let hemi = root.child(2);
    let mut all = vec![
        RtResult {
            key: root.clone(),
            record: Record::Shaded {
                base: c(0.1),
                children: vec![
                    Child::Trace(c(0.5)),
                    Child::Shadow,
                    Child::Ambient(c(0.7)),
                    Child::AmbientKnown(c(0.3) * c(0.2)),
                ],
                attenuation: None,
            },
        },
        RtResult {
            key: hemi.clone(),
            record: Record::Hemisphere { strata: 3 },
        },
        RtResult {
            key: root.child(0),
            record: Record::Value(c(0.25)),
        },
        RtResult {
            key: root.child(1),
            record: Record::Value(c(0.125)),
        },
    ];
    for (k, v) in [(0, c(0.4)), (1, Color::splat(f64::NAN)), (2, c(0.9))] {
        all.push(RtResult {
            key: hemi.child(k),
            record: Record::Value(v),
        });
    }
    let mean = (c(0.4) / 1.0 + Color::ZERO / 1.0 + c(0.9) / 1.0) / 3.0;
    let mut expected = c(0.1);
    expected += c(0.7) * mean;
    expected += c(0.3) * c(0.2);
    expected += c(0.5) * c(0.25);
    expected += c(0.125);
    // Every rotation of the list, forwards and backwards.
    for shift in 0..all.len() {
        let mut order: Vec<&RtResult> = all.iter().cycle().skip(shift).take(all.len()).collect();
        for _ in 0..2 {
            let mut t = PixelTrees::default();
            for r in &order {
                t.merge((*r).clone());
            }
            assert_eq!(t.pixels, vec![(3, expected)], "shift {shift}");
            assert_eq!(t.pending(), 0);
            order.reverse();
        }
    }
}

#[test]
fn a_missing_child_leaves_the_pixel_pending() {
    let mut t = PixelTrees::default();
    t.merge(RtResult {
        key: NodeKey::root(1),
        record: Record::Shaded {
            base: c(0.1),
            children: vec![Child::Shadow, Child::Shadow],
            attenuation: None,
        },
    });
    t.merge(RtResult {
        key: NodeKey::root(1).child(1),
        record: Record::Value(c(0.2)),
    });
    assert!(t.pixels.is_empty());
    assert_eq!(t.pending(), 1);
}

/// A bundle run where its point was shaded carries its value in the
/// record: the pixel equals the one whose every bundle sent a result,
/// bit for bit, with scattering added after the attenuation either way,
/// and a record awaiting nothing is never held.
#[test]
fn carried_values_give_the_value_of_results_sent() {
    let key = NodeKey::root(3);
    let record = |children| RtResult {
        key: key.clone(),
        record: Record::Shaded {
            base: c(0.1),
            children,
            attenuation: Some((c(0.7), c(0.01))),
        },
    };
    let value = |i: usize, v: f64| RtResult {
        key: key.child(i),
        record: Record::Value(c(v)),
    };
    let mut sent = PixelTrees::default();
    sent.merge(value(2, 0.3));
    sent.merge(record(vec![Child::Shadow, Child::Shadow, Child::Scatter]));
    sent.merge(value(0, 0.123));
    sent.merge(value(1, 0.456));
    let mut mixed = PixelTrees::default();
    mixed.merge(record(vec![
        Child::Known(c(0.123)),
        Child::Shadow,
        Child::KnownScatter(c(0.3)),
    ]));
    assert!(mixed.pixels.is_empty());
    assert_eq!(mixed.pending(), 1);
    mixed.merge(value(1, 0.456));
    let mut carried = PixelTrees::default();
    carried.merge(record(vec![
        Child::Known(c(0.123)),
        Child::Known(c(0.456)),
        Child::KnownScatter(c(0.3)),
    ]));
    assert_eq!(carried.peak_pending, 0, "nothing awaited, nothing held");
    let expected = (c(0.1) + c(0.123) + c(0.456)) * c(0.7) + c(0.01) + c(0.3);
    for t in [&sent, &mixed, &carried] {
        assert_eq!(t.pixels, vec![(3, expected)]);
        assert_eq!(t.pending(), 0);
    }
}

/// A super-sampling hemisphere is handed to the workload once its first
/// samples are in, whatever came first (its record or its samples' values),
/// with the values in child order; then again once its super-samples are;
/// its value, delivered, finishes the pixel.
#[test]
fn super_sampling_hemispheres_are_wanted_after_each_pass() {
    use crate::render::ambient::AmbientRequest;
    use crate::render::RayTask;
    let seed = HemisphereSeed {
        task: RayTask::primary(
            crate::geometry::Ray::new(glam::DVec3::ZERO, glam::DVec3::Z),
            0.0,
            f64::INFINITY,
            1,
        ),
        req: AmbientRequest {
            point: glam::DVec3::ZERO,
            normal: glam::DVec3::Z,
            coef: c(0.5),
            offset_scale: 1.0,
            side: 0,
        },
    };
    let node = NodeKey::root(3);
    let sample = |i: usize, v: f64| RtResult {
        key: node.child(i),
        record: Record::Value(c(v)),
    };
    for record_first in [true, false] {
        let mut t = PixelTrees::default();
        let record = RtResult {
            key: node.clone(),
            record: Record::SuperHemisphere {
                strata: 3,
                seed: Box::new(seed.clone()),
            },
        };
        if record_first {
            t.merge(record.clone());
        }
        t.merge(sample(2, 0.3));
        t.merge(sample(0, 0.1));
        assert!(t.wanted.is_empty(), "a first sample is missing");
        t.merge(sample(1, 0.2));
        if !record_first {
            assert!(t.wanted.is_empty(), "the record is missing");
            t.merge(record);
        }
        let w = t.wanted.pop().expect("first pass in");
        assert_eq!(w.key, node);
        assert_eq!(w.values, vec![c(0.1), c(0.2), c(0.3)]);
        assert_eq!(w.state.second, None);
        let state = SuperState {
            second: Some(vec![2, 0]),
            ..w.state
        };
        t.await_second(&node, state, &w.values);
        t.merge(sample(4, 0.5));
        assert!(t.wanted.is_empty() && t.pixels.is_empty());
        t.merge(sample(3, 0.4));
        let w = t.wanted.pop().expect("second pass in");
        assert_eq!(w.values, vec![c(0.1), c(0.2), c(0.3), c(0.4), c(0.5)]);
        assert_eq!(w.state.second, Some(vec![2, 0]));
        t.deliver(w.key, c(0.25));
        assert_eq!(t.pixels, vec![(3, c(0.25))]);
        assert_eq!(t.pending(), 0);
    }
}

#[test]
fn shipped_pixels_leave_the_processor_and_join_the_masters_picture() {
    let mut proc = PixelTrees::default();
    let mut master = PixelTrees::default();
    for (i, p) in [4u32, 9, 2].into_iter().enumerate() {
        proc.merge(RtResult {
            key: NodeKey::root(p),
            record: Record::Value(c(i as f64)),
        });
    }
    assert_eq!(proc.finished(), 3);
    let batch = proc.ship_pixels();
    // Priced by its pixels, as the runtimes' byte counts see it.
    let bare = RtResult {
        key: NodeKey::default(),
        record: Record::Pixels(Vec::new()),
    };
    assert_eq!(batch.byte_size(), bare.byte_size() + 3 * 32);
    assert!(proc.pixels.is_empty());
    assert_eq!((proc.shipped, proc.finished()), (3, 3));
    let place = |master: &mut PixelTrees, batch: RtResult| match batch.record {
        Record::Pixels(pixels) => master.place_batch(12, pixels),
        other => panic!("not a batch: {other:?}"),
    };
    place(&mut master, batch);
    proc.merge(RtResult {
        key: NodeKey::root(5),
        record: Record::Value(c(7.0)),
    });
    place(&mut master, proc.ship_pixels());
    // Merged without the workload, a batch is held as the processors'
    // pixels are.
    let mut held = PixelTrees::default();
    held.merge(RtResult {
        key: NodeKey::default(),
        record: Record::Pixels(vec![(3, c(1.0))]),
    });
    assert_eq!(held.pixels, vec![(3, c(1.0))]);
    assert_eq!(proc.finished(), 4);
    assert_eq!(master.pending(), 0);
    let picture = master.picture.take().expect("the master's picture");
    assert_eq!(
        (picture.len(), picture.placed(), picture.fault()),
        (12, 4, None)
    );
    let film = picture.into_film(4, 3).expect("12 pixels");
    let want = [(4, 0.0), (9, 1.0), (2, 2.0), (5, 7.0)];
    for i in 0..12 {
        let v = want.iter().find(|w| w.0 == i).map_or(0.0, |w| w.1);
        assert_eq!(film.get(i % 4, i / 4), c(v), "pixel {i}");
    }
}
