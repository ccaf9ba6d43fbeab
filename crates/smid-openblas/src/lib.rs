//! The system OpenBLAS behind Clarabel's PSD cones (smid's moment relaxation, `smid-core`'s
//! feature `sdp`), kept single-threaded.
//!
//! The moment relaxation factors thousands of tiny (6x6) blocks. A threaded OpenBLAS (Debian's
//! default `openblas-pthread`) hands each to its thread pool, whose threads spin for work: on a
//! loaded machine with few cores the spinning threads starve each other and a relaxation runs
//! hundreds of times slower than on one thread. [`single_threaded`] sets the
//! pool to one thread, whatever the environment says (`OPENBLAS_NUM_THREADS` is read only when
//! the library loads, before `main`). Calling into OpenBLAS is the point of this crate, so it is
//! the one crate of smid with `unsafe` code: one call of a C function without arguments that
//! could be invalid.
#![deny(unsafe_code)]
#![warn(missing_docs)]

use std::os::raw::c_int;
use std::sync::Once;

// Link the library (the `system` feature emits `-lopenblas`).
use openblas_src as _;

#[allow(unsafe_code)]
extern "C" {
    /// OpenBLAS's own setter of its thread count (cblas.h).
    fn openblas_set_num_threads(num_threads: c_int);
}

static ONCE: Once = Once::new();

/// Make OpenBLAS single-threaded (once per process; later calls do nothing).
pub fn single_threaded() {
    ONCE.call_once(|| {
        // SAFETY: a plain C setter taking an int; 1 is always a valid thread count.
        #[allow(unsafe_code)]
        unsafe {
            openblas_set_num_threads(1)
        }
    });
}

#[cfg(test)]
mod tests {
    #[test]
    fn setting_the_thread_count_links_and_returns() {
        super::single_threaded();
        super::single_threaded();
    }
}
