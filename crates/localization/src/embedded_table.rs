//! The reference table compiled into the binary: a measured table when the build names one with the
//! environment variable `CMA_TABLE`, the ideal-model 5° table otherwise.
//!
//! `build.rs` reads the file named by `CMA_TABLE` (an absolute path, or one relative to the
//! `core-nostd` directory) with `cma_formats::table_file::parse`, fails the build with the parser's message
//! if the file is bad, and emits its arrays as `static`s (`MEASURED_*` in [`crate::tables`]), so the
//! table sits in flash once. It holds the rows of both feature kinds (magnitude and active; a
//! version-1 file's active rows are its magnitude features and ½), or with
//! `CMA_TABLE_FEATURES=active` / `magnitude` only the rows of one kind, and then serves only that
//! kind (`ReferenceTable::serves`; the locator refuses a configuration of the other kind). Flash
//! cost: 24·F·Q + 40·F + 4·Q bytes (f32) for both kinds, 12·F·Q + 12·F (active) or 24·F
//! (magnitude) + 4·F + 4·Q for one, e.g. 74.5 KB or 37.2 KB (active) for the default calibration
//! (Q = 72, F = 42), 13.0 KB or 6.5 KB for a 15° grid with 21 rows (Q = 24, F = 21). Rebuilds follow
//! changes of the variables and of the file.
//!
//! ```text
//! CMA_TABLE=/abs/path/array42.cmat cargo build --release -p firmware
//! CMA_TABLE=/abs/path/array42.cmat CMA_TABLE_FEATURES=active cargo build --release -p firmware
//! ```
//! The firmware localizes with `ReferenceTable::embedded()` (and the self-calibration off when the
//! table is measured).

use crate::reference_table::ReferenceTable;

/// True when this build embeds a measured table (`CMA_TABLE` was set).
pub const HAS_MEASURED_TABLE: bool = cfg!(cma_measured_table);

impl ReferenceTable<'static> {
    /// The table embedded at build time: the measured one named by `CMA_TABLE`, else
    /// [`ReferenceTable::ideal_5deg`].
    #[must_use]
    pub fn embedded() -> ReferenceTable<'static> {
        #[cfg(cma_measured_table)]
        {
            #[cfg(cma_table_active)]
            use crate::tables::{MEASURED_ACTIVE, MEASURED_NOISE_ACTIVE};
            use crate::tables::{MEASURED_AZIMUTHS, MEASURED_FREQS};
            #[cfg(cma_table_magnitude)]
            use crate::tables::{
                MEASURED_FEATURES, MEASURED_NOISE_MAGNITUDE, MEASURED_NOISE_POWER,
            };
            // Note: build.rs validated shape and content with the same rules as the constructors,
            // so this cannot fail; the ideal table is only a formal fallback.
            #[cfg(cma_table_magnitude)]
            let table = ReferenceTable::new(
                &MEASURED_AZIMUTHS,
                &MEASURED_FREQS,
                &MEASURED_FEATURES,
                &MEASURED_NOISE_MAGNITUDE,
                &MEASURED_NOISE_POWER,
            );
            #[cfg(all(cma_table_magnitude, cma_table_active))]
            let table = table.and_then(|t| t.with_active(&MEASURED_ACTIVE, &MEASURED_NOISE_ACTIVE));
            #[cfg(all(cma_table_magnitude, not(cma_table_active)))]
            let table = table.map(|t| t.only(crate::features::FeatureKind::Magnitude));
            #[cfg(all(cma_table_active, not(cma_table_magnitude)))]
            let table = ReferenceTable::active_only(
                &MEASURED_AZIMUTHS,
                &MEASURED_FREQS,
                &MEASURED_ACTIVE,
                &MEASURED_NOISE_ACTIVE,
            );
            if let Ok(t) = table {
                return t;
            }
        }
        ReferenceTable::ideal_5deg()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn embedded_is_ideal_without_cma_table() {
        if !HAS_MEASURED_TABLE {
            assert_eq!(ReferenceTable::embedded(), ReferenceTable::ideal_5deg());
        } else {
            // CMA_TABLE=… cargo test -p cma-core --lib embedded
            let t = ReferenceTable::embedded();
            assert_ne!(t, ReferenceTable::ideal_5deg());
            assert_eq!(t.features().len(), t.num_freqs() * t.num_azimuths());
            assert_eq!(t.active_features().len(), t.features().len());
            use crate::features::FeatureKind;
            assert_eq!(t.serves(FeatureKind::Magnitude), cfg!(cma_table_magnitude));
            assert_eq!(t.serves(FeatureKind::Active), cfg!(cma_table_active));
        }
    }
}
