//! Volumetric error identification from tool-tip (laser-tracker)
//! measurements (\[R2\] in docs/references.md): the measurement model, identification with
//! identifiability analysis, validation at held-out poses, measurement
//! planning, simulation and compensation.

pub mod compensate;
pub mod doc;
pub mod identify;
pub mod model;
pub mod plan;
pub mod simulate;
pub mod validate;

pub use doc::{
    CompensatePointsDoc, TrackerIdentifyDoc, TrackerPlanDoc, TrackerSimulateDoc, TrackerValidateDoc,
};
pub use identify::{
    Identification, IdentifyInputs, IdentifyOptions, TrackerIdentifyError, identify,
};
pub use model::{TrackerModel, TrackerPoint};
pub use validate::{ErrorStats, Stats, Validation, validate};
