//! Tests of the wire format and the rank's bookkeeping.

use super::*;
use crate::protocol::message::Msg;
use crate::tests::Mini;

fn packet() -> Packet<Mini> {
    Packet {
        from: Addr::Proc(1),
        to: Addr::Master,
        class: Class::Control,
        items: vec![
            Msg::WorkRequest { roots: true },
            Msg::Credit([(2, 64), (3, 120)]),
        ],
        bytes: 48,
        load: 7,
    }
}

#[test]
fn packets_round_trip() {
    let p = packet();
    let bytes = encode_packet(&p).unwrap();
    let q = decode_packet::<Mini>(&bytes, 1, 0).unwrap();
    assert_eq!(q.from, p.from);
    assert_eq!(q.to, p.to);
    assert_eq!(q.class, p.class);
    assert_eq!(q.bytes, p.bytes);
    assert_eq!(q.load, p.load);
    assert_eq!(format!("{:?}", q.items), format!("{:?}", p.items));
}

/// The epoch messages cross the wire whole: the broadcast's items, not
/// only their count (which is all their `Debug` shows).
#[test]
fn epoch_messages_round_trip() {
    let p: Packet<Mini> = Packet {
        from: Addr::Master,
        to: Addr::Proc(2),
        class: Class::Data,
        items: vec![
            Msg::Broadcast {
                epoch: 3,
                items: vec![
                    (7, crate::tests::Item(vec![1, 2, 3])),
                    (9, crate::tests::Item(vec![])),
                ],
            },
            Msg::BroadcastHeld(3),
        ],
        bytes: 96,
        load: 0,
    };
    let q = decode_packet::<Mini>(&encode_packet(&p).unwrap(), 0, 2).unwrap();
    match q.items.as_slice() {
        [Msg::Broadcast { epoch: 3, items }, Msg::BroadcastHeld(3)] => {
            assert_eq!(
                format!("{items:?}"),
                "[(7, Item([1, 2, 3])), (9, Item([]))]"
            );
        }
        other => panic!("decoded {other:?}"),
    }
}

/// The final report crosses the wire whole, whatever its statistics
/// hold: postcard is not self-describing, so a field left out when it
/// has its default value would shift every field after it.
#[test]
fn final_reports_round_trip() {
    for completed in [false, true] {
        let mut stats = ProcStats::new(Addr::Proc(1));
        stats.cache_completed = completed;
        stats.data_items_served = 17;
        stats.epochs = 2;
        let report: FinalReport<Mini> = FinalReport {
            rank: 1,
            nodes: vec![(Addr::Proc(1), Default::default(), stats)],
            traffic: RankTraffic::default(),
        };
        let bytes = postcard::to_stdvec(&report).unwrap();
        let back: FinalReport<Mini> = decode(&bytes, "final report", 1, 0).unwrap();
        let s = &back.nodes[0].2;
        assert_eq!(s.cache_completed, completed);
        assert_eq!((s.data_items_served, s.epochs), (17, 2));
    }
}

#[test]
fn garbage_is_a_clear_error_naming_both_ranks() {
    let err = decode_packet::<Mini>(b"not a packet", 3, 2).expect_err("garbage must not decode");
    let text = err.to_string();
    assert!(text.contains("rank 2"), "{text}");
    assert!(text.contains("from rank 3"), "{text}");
    assert!(text.contains("cannot decode"), "{text}");
    assert!(text.contains("12-byte"), "{text}");
}

#[test]
fn truncated_and_padded_messages_are_rejected() {
    let bytes = encode_packet(&packet()).unwrap();
    for cut in 0..bytes.len() {
        let err = decode_packet::<Mini>(&bytes[..cut], 1, 0).err();
        assert!(err.is_some(), "a packet cut to {cut} bytes decoded");
    }
    let mut padded = bytes.clone();
    padded.push(0);
    let text = decode_packet::<Mini>(&padded, 1, 0)
        .expect_err("trailing bytes must be rejected")
        .to_string();
    assert!(text.contains("left over"), "{text}");
}

#[test]
fn faults_are_read_for_one_rank_only() {
    assert_eq!(Fault::parse("garbage:1", 1), Some(Fault::Garbage));
    assert_eq!(Fault::parse("garbage:1", 0), None);
    assert_eq!(Fault::parse("exit: 2", 2), Some(Fault::Exit));
    assert_eq!(Fault::parse("no-server:0", 0), Some(Fault::NoServer));
    assert_eq!(Fault::parse("explode:0", 0), None);
    assert_eq!(Fault::parse("", 0), None);
}

/// SEMANTICS.md states the MPI thread's bounds on data replies: they are
/// these constants.
#[test]
fn the_semantics_state_the_reply_bounds_in_force() {
    let text = include_str!("../../../SEMANTICS.md");
    let text = text.split_whitespace().collect::<Vec<_>>().join(" ");
    let part = format!(
        "replies of at most {} MiB of items each",
        serve::REPLY_PART_BYTES >> 20
    );
    let sending = format!("hold less than {} MiB", transport::SENDING_BYTES >> 20);
    assert!(text.contains(&part), "SEMANTICS.md should say: {part}");
    assert!(
        text.contains(&sending),
        "SEMANTICS.md should say: {sending}"
    );
    assert_eq!(serve::REPLY_PART_BYTES % (1 << 20), 0);
    assert_eq!(transport::SENDING_BYTES % (1 << 20), 0);
}
