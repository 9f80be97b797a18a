//! Table 2: memory high-water by category.

use serde::Serialize;

use super::harness::Ctx;
use crate::report::table::Table;
use crate::{Error, Result};

/// One processor's high-water marks, in bytes unless named otherwise. All
/// are measured in the run (the octree is the one it traced).
#[derive(Serialize)]
struct MemoryRow {
    processor: usize,
    resident: u64,
    cache: u64,
    /// The replicated octree, as built.
    octree: u64,
    /// The largest selection (cell ids) one pyramid clipping returned.
    clipping: u64,
    /// Primary-ray tasks (tiles) held from hand-out to execution.
    primary_tasks: u64,
    waiting_tasks: u64,
    input_buffer: u64,
    send_backlog: u64,
    /// Input buffer plus send backlog at one moment.
    in_flight: u64,
    pixel_trees_nodes: usize,
    send_backlog_messages: u64,
}

impl MemoryRow {
    /// What the paper's table adds up: every category in bytes.
    fn total(&self) -> u64 {
        self.resident
            + self.cache
            + self.octree
            + self.clipping
            + self.primary_tasks
            + self.waiting_tasks
            + self.in_flight
    }
}

pub(super) fn memory(cx: &mut Ctx) -> Result<()> {
    let r = cx.detail()?;
    let rows: Vec<MemoryRow> = r
        .stats
        .procs
        .iter()
        .enumerate()
        .map(|(i, p)| MemoryRow {
            processor: i,
            resident: p.memory.resident_bytes,
            cache: p.memory.cached_bytes,
            octree: r.octree_bytes,
            clipping: p.memory.selection_bytes as u64,
            primary_tasks: p.memory.root_task_bytes as u64,
            waiting_tasks: p.memory.waiting_task_bytes as u64,
            input_buffer: p.memory.input_buffer_bytes as u64,
            send_backlog: p.memory.send_backlog_bytes as u64,
            in_flight: p.memory.in_flight_bytes as u64,
            pixel_trees_nodes: r.procs.get(i).map_or(0, |s| s.peak_tree_nodes),
            send_backlog_messages: p.memory.send_backlog as u64,
        })
        .collect();
    // The paper reports its processor 1 of 16; we add the one with the most.
    let worst = rows
        .iter()
        .max_by_key(|m| m.total())
        .map_or(0, |m| m.processor);
    let first = 1.min(rows.len().saturating_sub(1));
    let kib = |b: u64| format!("{:.1}", b as f64 / 1024.0);
    let (a, b) = (&rows[first], &rows[worst]);
    let mut t = Table::new([
        "category".to_string(),
        format!("processor {first} (KiB)"),
        format!("processor {worst}, the largest total (KiB)"),
    ]);
    let mut row = |name: &str, f: &dyn Fn(&MemoryRow) -> String| {
        t.row([name.to_string(), f(a), f(b)]);
    };
    row("resident objects (its partition)", &|m| kib(m.resident));
    row("object cache", &|m| kib(m.cache));
    row("octree (replicated, as built)", &|m| kib(m.octree));
    row("pyramid clipping (largest selection)", &|m| kib(m.clipping));
    row("primary-ray tasks (tiles held)", &|m| kib(m.primary_tasks));
    row("tasks waiting for data", &|m| kib(m.waiting_tasks));
    row("input buffer (credit-limited messages)", &|m| {
        kib(m.input_buffer)
    });
    row("send backlog", &|m| kib(m.send_backlog));
    row("in flight (input buffer + send backlog)", &|m| {
        kib(m.in_flight)
    });
    row("total", &|m| kib(m.total()));
    row("pixel ray-tree nodes held (count)", &|m| {
        m.pixel_trees_nodes.to_string()
    });
    row("send backlog (messages)", &|m| {
        m.send_backlog_messages.to_string()
    });
    let mut all = Table::new([
        "processor",
        "resident KiB",
        "cache KiB",
        "clipping KiB",
        "primary KiB",
        "waiting KiB",
        "input buffer KiB",
        "backlog KiB",
        "in flight KiB",
    ]);
    for m in &rows {
        all.row([
            m.processor.to_string(),
            kib(m.resident),
            kib(m.cache),
            kib(m.clipping),
            kib(m.primary_tasks),
            kib(m.waiting_tasks),
            kib(m.input_buffer),
            kib(m.send_backlog),
            kib(m.in_flight),
        ]);
    }
    cx.finish(
        "memory",
        "Table 2: memory high-water by category",
        &format!(
            "Processor {first} (the paper reports its processor 1) and processor {worst} (the largest total) of {}, then all processors. \
             Every figure is a high-water mark measured in the run; the total adds them up, as the paper's table does, \
             though they need not peak at the same moment. The octree is replicated: every processor holds all {} KiB of it.",
            r.options.procs,
            kib(r.octree_bytes)
        ),
        &[t, all],
        serde_json::to_value(&rows).map_err(|e| Error::Other(format!("json: {e}")))?,
    )
}
