//! Table 2: memory high-water by category.

use serde::Serialize;

use super::harness::Ctx;
use crate::report::table::Table;
use crate::{Error, Result};

#[derive(Serialize)]
struct MemoryRow {
    processor: usize,
    resident: u64,
    cache: u64,
    waiting_tasks: u64,
    input_buffer: u64,
    pixel_trees_nodes: usize,
    send_backlog_messages: u64,
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
            waiting_tasks: p.memory.waiting_task_bytes as u64,
            input_buffer: p.memory.input_buffer_bytes as u64,
            pixel_trees_nodes: r.procs.get(i).map_or(0, |s| s.peak_tree_nodes),
            send_backlog_messages: p.memory.send_backlog as u64,
        })
        .collect();
    // The paper reports one of its 16 processors: the one with the most.
    let worst = rows
        .iter()
        .max_by_key(|m| m.resident + m.cache + m.waiting_tasks + m.input_buffer)
        .map_or(0, |m| m.processor);
    let m = &rows[worst];
    let kib = |b: u64| format!("{:.1}", b as f64 / 1024.0);
    let mut t = Table::new(["category", "high-water (KiB)"]);
    t.row([
        "resident objects (its partition)".to_string(),
        kib(m.resident),
    ]);
    t.row(["object cache".to_string(), kib(m.cache)]);
    t.row(["tasks waiting for data".to_string(), kib(m.waiting_tasks)]);
    t.row([
        "input buffer (credit-limited messages)".to_string(),
        kib(m.input_buffer),
    ]);
    t.row([
        "pixel ray-tree nodes held".to_string(),
        m.pixel_trees_nodes.to_string(),
    ]);
    t.row([
        "send backlog (messages)".to_string(),
        m.send_backlog_messages.to_string(),
    ]);
    let mut all = Table::new([
        "processor",
        "resident KiB",
        "cache KiB",
        "waiting KiB",
        "input buffer KiB",
    ]);
    for m in &rows {
        all.row([
            m.processor.to_string(),
            kib(m.resident),
            kib(m.cache),
            kib(m.waiting_tasks),
            kib(m.input_buffer),
        ]);
    }
    cx.finish(
        "memory",
        "Table 2: memory high-water by category",
        &format!(
            "Processor {worst} of {} (the one with the largest total), then all processors.",
            r.options.procs
        ),
        &[t, all],
        serde_json::to_value(&rows).map_err(|e| Error::Other(format!("json: {e}")))?,
    )
}
