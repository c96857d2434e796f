//! The JSON products of lidarqa, one serde type each: the command that writes a product
//! serialises this type and the report deserialises the same type, so the two cannot drift apart.
//!
//! Lengths are metres and angles degrees unless a field says otherwise. A product only lidarqa
//! writes denies unknown fields: a field the writer adds must be added here, where the reader
//! sees it too. One users may also write by hand (`calibration.json`) ignores them, and the
//! round-trip tests of the commands' output catch a field missing here instead.

mod budget;
mod calibration;
mod evaluate;
mod overlap;
mod qc;
mod tpu_summary;
mod truth;
mod values;

pub use budget::{
    Budget, BudgetDocument, BudgetSource, BudgetSweep, BudgetSweepDocument, BudgetSweepPoint,
    Displacement, Footprint, GeometryFacts, MonteCarloSigma,
};
pub use calibration::{
    CalibrationDocument, CalibrationIterationsDocument, CalibrationTie, CalibrationTrajectorySigma,
    DroppedPick, FoundLine, FoundLines, Iteration, NorthEastUp, NotSeparable, RollPitchHeading,
    StripAdjustmentBlock, StripLine, TiePosition, TieRms, TrajectorySigmaTest,
};

pub use evaluate::{
    Asprs, AsprsComponent, EvaluateDocument, Evaluation, Nssda, PointResidual, Position,
    VerticalEvaluation, VerticalResidual,
};
pub use overlap::{OverlapDocument, OverlapGrid, OverlapPair, OverlapProfile, OverlapProfileStrip};
pub use qc::{
    IhoDepthBand, IhoDocument, IhoDocumentOrder, QC_FORMAT, QcDensity, QcDocument, QcIho,
    QcIhoOrder, QcInterswath, QcIntraswath, QcLine, QcLines, QcNva, QcPredicted, QcRaster,
    QcRequirement, QcSmoothCells, QcVerdict,
};
pub use tpu_summary::{
    GridGeometry, IhoBand, IhoOrderLine, IncidenceCounts, LinearHistogram, MountingCheck,
    OrderGrid, RecoveryResidual, ScanAngleCheck, SigmaGrid, SigmaHistograms, SoundingsIho, Stats,
    TileLine, TpuSummaryDocument,
};
pub use truth::{
    InjectedErrors, LineErrorTruth, MountingParameters, RandomErrors, StripTruth, TargetTruth,
    TruthDocument,
};
pub use values::{Id, Ordered, StripId};
