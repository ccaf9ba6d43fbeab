//! Stage 3 (paper Section 5) by a moment (SDP) relaxation of the shared-error EIV problem
//! (eqs 1, 28-30) on cliques of consecutive samples, planned behind a cargo feature `sdp`
//! (Clarabel's PSD cone over OpenBLAS). It is not built yet: selecting `method.eiv: sdp` is a
//! clear error that names the feature and the alternative (`shared`, which is already within a
//! few percent of the exact set on the paper's example; see [`crate::eiv_exact`]).
use crate::eiv::{EivProblem, EivResult};
use crate::error::{Result, SmidError};

/// The SDP relaxation: not available in this build (an error naming the feature).
pub fn solve(_prob: &EivProblem) -> Result<EivResult> {
    Err(SmidError::Unsupported {
        plugin: "smid-core".into(),
        what: "`method.eiv: sdp` in this build: the moment relaxation needs the cargo feature `sdp` (clarabel `sdp-openblas`), which this version does not provide yet; choose `shared` (within a few percent of the exact set) or `exact-grid`".into(),
    })
}

#[cfg(test)]
mod tests {
    #[test]
    fn selecting_sdp_names_the_feature() {
        let out = [];
        let input = [];
        let prob = crate::eiv::EivProblem {
            na: 0,
            nb: 0,
            fixed: vec![None],
            unit_gain: false,
            output: &out,
            input: &input,
            use_band_samples: false,
        };
        let e = super::solve(&prob).unwrap_err().to_string();
        assert!(e.contains("feature `sdp`") && e.contains("shared"), "{e}");
    }
}
