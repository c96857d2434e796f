//! The JSON products of lidarqa, one serde type each: the command that writes a product
//! serialises this type and the report deserialises the same type, so the two cannot drift apart.
//!
//! Lengths are metres and angles degrees unless a field says otherwise. Every type denies unknown
//! fields: a field the writer adds must be added here, where the reader sees it too.

mod tpu_summary;

pub use tpu_summary::{
    GridGeometry, IhoBand, IhoOrderLine, IncidenceCounts, LinearHistogram, MountingCheck,
    OrderGrid, RecoveryResidual, ScanAngleCheck, SigmaGrid, SigmaHistograms, SoundingsIho, Stats,
    TileLine, TpuSummaryDocument,
};
