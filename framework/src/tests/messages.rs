//! Messages: serialisation and the outbox's bundling and credits.

use super::*;

#[test]
fn packets_round_trip_through_serde() {
    let packet: Packet<Mini> = Packet {
        from: Addr::Proc(1),
        to: Addr::Master,
        class: Class::DemandDriven,
        items: vec![
            Msg::Dd(DdEnvelope {
                task: Task { key: 5, depth: 1 },
                origin: Some(1),
                handout: false,
                root: false,
            }),
            Msg::DataReply(vec![(3, Item(vec![1, 2]))]),
            Msg::ProbeReply {
                wave: 2,
                sent: 10,
                received: 9,
            },
            Msg::Broadcast {
                epoch: 1,
                items: vec![(4, Item(vec![5]))],
            },
            Msg::BroadcastHeld(1),
        ],
        bytes: 100,
        load: 0,
    };
    let json = serde_json::to_string(&packet).expect("serialise");
    let back: Packet<Mini> = serde_json::from_str(&json).expect("deserialise");
    assert_eq!(format!("{back:?}"), format!("{packet:?}"));
}

fn dd(key: u64) -> Msg<Mini> {
    Msg::Dd(DdEnvelope {
        task: Task { key, depth: 0 },
        origin: None,
        handout: false,
        root: false,
    })
}

#[test]
fn outbox_bundles_by_count_and_flush_and_sends_urgent_at_once() {
    let bundle = BundleConfig {
        enabled: true,
        max_items: 3,
        max_bytes: 1 << 20,
        max_age: std::time::Duration::from_secs(1),
    };
    let mut out: Outbox<Mini> = Outbox::new(Addr::Proc(0), 2, bundle, 100, 1 << 20);
    out.push(Addr::Proc(1), dd(1), 0);
    out.push(Addr::Proc(1), dd(2), 0);
    assert!(!out.has_ready(), "not yet a full bundle");
    out.push(Addr::Proc(1), Msg::DataRequest(vec![4]), 0);
    let urgent = out.take_ready();
    assert_eq!(urgent.len(), 1);
    assert_eq!(urgent[0].class, Class::Data);
    out.push(Addr::Proc(1), dd(3), 0);
    let full = out.take_ready();
    assert_eq!(full.len(), 1);
    assert_eq!(full[0].items.len(), 3, "one bundle of three");
    out.push(Addr::Proc(1), dd(4), 10);
    out.pump(10 + 999_999_999, false);
    assert!(!out.has_ready(), "younger than max_age");
    out.pump(10 + 1_000_000_000, false);
    assert_eq!(out.take_ready().len(), 1, "sent by age");
    out.push(Addr::Master, dd(5), 0);
    out.pump(0, true);
    assert_eq!(out.take_ready().len(), 1, "flushed");
    assert!(out.is_empty());
}

#[test]
fn outbox_holds_messages_without_credit_and_never_drops() {
    // 2 credits (and one more that only results may use).
    let mut out: Outbox<Mini> = Outbox::new(Addr::Proc(0), 2, BundleConfig::default(), 2, 1 << 20);
    let b = dd(0).byte_size() as u64;
    for k in 0..5 {
        out.push(Addr::Proc(1), dd(k), 0);
    }
    out.pump(0, true);
    let first = out.take_ready();
    assert_eq!(first.iter().map(|p| p.items.len()).sum::<usize>(), 2);
    assert_eq!(out.backlog(), 3);
    assert_eq!(out.credits_towards(Addr::Proc(1), Pool::Tasks), 0);
    assert_eq!(out.credits_towards(Addr::Proc(1), Pool::Results), 1);
    out.pump(0, true);
    assert!(!out.has_ready(), "no credit, nothing sent");
    out.grant(Addr::Proc(1), [(2, 2 * b), (0, 0)], 0);
    out.pump(0, true);
    assert_eq!(
        out.take_ready()
            .iter()
            .map(|p| p.items.len())
            .sum::<usize>(),
        2
    );
    out.grant(Addr::Proc(1), [(5, 2 * b), (0, 0)], 0);
    out.pump(0, true);
    let last = out.take_ready();
    assert_eq!(last.iter().map(|p| p.items.len()).sum::<usize>(), 1);
    assert!(out.is_empty());
    assert_eq!(out.backlog_high_water(), 5);
    // Data traffic is never credit-limited.
    for _ in 0..10 {
        out.push(Addr::Proc(1), Msg::DataRequest(vec![1]), 0);
    }
    assert_eq!(out.take_ready().len(), 10);
}

#[test]
fn the_byte_window_holds_messages_and_lets_a_large_one_go_alone() {
    let b = dd(0).byte_size();
    // Credits for 100 messages, but a window of two and a half messages.
    let window = 2 * b + b / 2;
    let mut out: Outbox<Mini> = Outbox::new(Addr::Proc(0), 2, BundleConfig::default(), 100, window);
    for k in 0..5 {
        out.push(Addr::Proc(1), dd(k), 0);
    }
    out.pump(0, true);
    let sent = |out: &mut Outbox<Mini>| {
        out.take_ready()
            .iter()
            .map(|p| p.items.len())
            .sum::<usize>()
    };
    assert_eq!(sent(&mut out), 2, "two fit the window");
    assert_eq!((out.backlog(), out.backlog_bytes()), (3, 3 * b));
    out.pump(0, true);
    assert_eq!(sent(&mut out), 0, "the window is full: nothing more goes");
    // One message's bytes come back: one more fits.
    out.grant(Addr::Proc(1), [(1, b as u64), (0, 0)], 0);
    out.pump(0, true);
    assert_eq!(sent(&mut out), 1);
    assert_eq!(out.in_flight_bytes(), 2 * b, "two still in the backlog");
    out.grant(Addr::Proc(1), [(2, 2 * b as u64), (0, 0)], 0);
    out.pump(0, true);
    assert_eq!(sent(&mut out), 2);
    assert_eq!(out.in_flight_bytes(), 0);
    // With nothing outstanding, a message larger than the window goes alone.
    let mut big: Outbox<Mini> = Outbox::new(Addr::Proc(0), 2, BundleConfig::default(), 100, 1);
    big.push(Addr::Proc(1), dd(0), 0);
    big.push(Addr::Proc(1), dd(1), 0);
    big.pump(0, true);
    assert_eq!(sent(&mut big), 1, "alone, never stuck");
    big.grant(Addr::Proc(1), [(1, b as u64), (0, 0)], 0);
    big.pump(0, true);
    assert_eq!(sent(&mut big), 1);
    assert!(big.is_empty());
}

/// Depth first ([`Workload::data_parallel_newest_first`]): data-parallel
/// tasks waiting for credit leave newest first, each packet's in the order
/// they were made (the receiver takes its newest first), and none is lost.
#[test]
fn newest_first_outbox_sends_the_newest_waiting_tasks_first() {
    let walk = |key: u64| {
        Msg::Dp(crate::protocol::message::DpEnvelope::<Mini> {
            task: Walk {
                key,
                path: vec![1],
                pos: 0,
                acc: 0,
                finish: None,
            },
            origin: None,
        })
    };
    let keys = |packets: Vec<Packet<Mini>>| {
        packets
            .iter()
            .map(|p| {
                p.items
                    .iter()
                    .map(|m| match m {
                        Msg::Dp(env) => env.task.key,
                        other => panic!("unexpected {other:?}"),
                    })
                    .collect::<Vec<_>>()
            })
            .collect::<Vec<_>>()
    };
    let to = Addr::Proc(1);
    let mut out: Outbox<Mini> = Outbox::new(Addr::Proc(0), 2, bundle_of_two(), 2, 1 << 20);
    out.send_dp_newest_first(true);
    for k in 0..5 {
        out.push(to, walk(k), 0);
    }
    // The first bundle of two left as soon as it was full, which spent
    // the link's credits; the other three wait.
    assert_eq!(keys(out.take_ready()), [vec![0, 1]]);
    assert_eq!(out.backlog(), 3);
    let b = (out.backlog_bytes() / 3) as u64;
    // Credits back: the newest two of the three waiting go, then the last.
    out.grant(to, [(2, 2 * b), (0, 0)], 0);
    out.pump(0, true);
    assert_eq!(keys(out.take_ready()), [vec![3, 4]]);
    out.grant(to, [(2, 2 * b), (0, 0)], 0);
    out.pump(0, true);
    assert_eq!(keys(out.take_ready()), [vec![2]]);
    assert!(out.is_empty());
    // Oldest first (the default), the same pushes leave in order.
    let mut fifo: Outbox<Mini> = Outbox::new(Addr::Proc(0), 2, bundle_of_two(), 2, 1 << 20);
    for k in 0..5 {
        fifo.push(to, walk(k), 0);
    }
    fifo.take_ready();
    fifo.grant(to, [(2, 2 * b), (0, 0)], 0);
    fifo.pump(0, true);
    assert_eq!(keys(fifo.take_ready()), [vec![2, 3]]);
}

fn bundle_of_two() -> BundleConfig {
    BundleConfig {
        enabled: true,
        max_items: 2,
        max_bytes: 1 << 20,
        max_age: std::time::Duration::from_secs(1),
    }
}
