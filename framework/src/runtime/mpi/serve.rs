//! The rank's data server on its MPI thread ([`crate::DataService::OnArrival`]).

use std::sync::Arc;

use super::transport::{decode_packet, encode_packet, host, runtime_err, DataHandler, Reply};
use super::RankLoop;
use crate::protocol::workload::Workload;
use crate::server::DataServer;

/// Most bytes (of the items, as [`crate::ByteSize`] counts them) in one
/// part of a data reply answered on arrival: a reply of a task's whole
/// selection is split, so that the MPI thread can hold back the rest while
/// the rank's sends in flight are many ([`super::transport::SENDING_BYTES`]).
pub(crate) const REPLY_PART_BYTES: usize = 1 << 20;

impl<W: Workload> RankLoop<'_, W> {
    /// Where the run answers data requests on arrival: gives the MPI
    /// thread the processor's data server (decoding each request and
    /// encoding its reply there). Whether it did.
    pub(super) fn install_data_handler(&mut self) -> bool {
        if self.fault == Some(super::Fault::NoServer) {
            return false;
        }
        let server = match self.nodes.first() {
            Some(Some(node)) if self.on_arrival => node.server(),
            _ => None,
        };
        let Some(server) = server else {
            return false;
        };
        let (rank, served) = (self.rank, Arc::clone(&self.served));
        let handler: DataHandler = Box::new(move |from, bytes| {
            let request = decode_packet::<W>(bytes, from, rank)?;
            if host(request.from) != from || !DataServer::is_request(&request) {
                return Err(runtime_err(format!(
                    "rank {rank}: rank {from} sent a message tagged as a data request that is not one from it"
                )));
            }
            let parts = server
                .serve_parts(request, REPLY_PART_BYTES)
                .map_err(|e| runtime_err(format!("rank {rank}: {e}")))?;
            {
                let mut t = served.lock().unwrap_or_else(|e| e.into_inner());
                t.messages_received += 1;
                t.bytes_received += bytes.len() as u64;
                t.data_messages_received += 1;
                t.data_bytes_received += bytes.len() as u64;
            }
            let served = Arc::clone(&served);
            // Each part is encoded only when the MPI thread sends it.
            let reply: Reply = Box::new(parts.into_iter().map(move |part| {
                let to = host(part.to);
                let out = encode_packet(&part)?;
                let mut t = served.lock().unwrap_or_else(|e| e.into_inner());
                t.messages_sent += 1;
                t.bytes_sent += out.len() as u64;
                Ok((to, out))
            }));
            Ok(reply)
        });
        *self.session.data.lock().unwrap_or_else(|e| e.into_inner()) = Some(handler);
        true
    }

    /// Adds what the MPI thread answered to the rank's traffic (once).
    pub(super) fn merge_served(&mut self) {
        let s = std::mem::take(&mut *self.served.lock().unwrap_or_else(|e| e.into_inner()));
        self.traffic.add_counts(&s);
    }
}
