//! Stage 3 (paper Section 5) by a moment (SDP) relaxation of the shared-error EIV problem
//! (eqs 1, 28-30): available with the cargo feature `sdp` (Clarabel's PSD cone over OpenBLAS).
//! Without the feature, selecting `method.eiv: sdp` is a clear error naming the feature.
use crate::eiv::{EivProblem, EivResult};
use crate::error::{Result, SmidError};

/// The SDP relaxation; without the `sdp` feature an error naming it.
#[cfg(not(feature = "sdp"))]
pub fn solve(_prob: &EivProblem) -> Result<EivResult> {
    Err(SmidError::Unsupported {
        plugin: "smid-core".into(),
        what: "`method.eiv: sdp` in this build: rebuild with the cargo feature `sdp` (e.g. `cargo build --release --features sdp`; needs apt libopenblas-dev libgfortran-12-dev), or choose `shared`".into(),
    })
}
