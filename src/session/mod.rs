//! What a run is beyond its samples: a render session from request to written
//! files (`run`: `Session`, which the command line and library callers share),
//! checkpoints to resume from (`checkpoint`),
//! shards of a render farm and their merge (`shard`), the pilot that chooses a
//! strategy for `strategy = "auto"` (`pilot`), the measurement of the
//! strategies' speed/accuracy trade (`converge`) and benchmarks (`bench`).

pub mod bench;
pub mod checkpoint;
pub mod converge;
pub mod pilot;
pub mod run;
pub mod shard;

pub use run::{Outcome, Outputs, PathSource, Request, Run, Session, SessionError, Setting};
