//! A configuration as a Rust constant expression, for the firmware's build script: the value the
//! board runs is written into its flash as a `const`, no parser on the target.
//!
//! A serde serializer that writes what it is given as Rust: structs as struct literals, enum variants
//! as `Enum::Variant`, floats with their type suffix (`1.5f32`), integers bare in the shortest form that
//! reads back to the same bits. Type names come from [`PATHS`]: a type new to the configuration is
//! an error naming it until it is added there.

use cma_core::LocatorConfig;
use serde::ser::{self, Serialize};
use std::fmt;

/// Where each configuration type lives, by the name its `Serialize` derive gives.
const PATHS: &[(&str, &str)] = &[
    ("ConfigFile", "cma_core::config::ConfigFile"),
    ("Method", "cma_core::config::Method"),
    ("Tracking", "cma_core::config::Tracking"),
    ("GridTracker", "cma_core::grid_tracker::GridTracker"),
    ("RefineCurve", "cma_core::refine_curve::RefineCurve"),
    ("DistancePower", "cma_core::refine_curve::DistancePower"),
    (
        "SimilarityMeasure",
        "cma_core::similarity::SimilarityMeasure",
    ),
    ("CurveKernel", "cma_core::curve_kernel::CurveKernel"),
    ("NoiseMixing", "cma_core::noisy_reference::NoiseMixing"),
    ("FeatureKind", "cma_core::features::FeatureKind"),
    ("Reliability", "cma_core::reliability::Reliability"),
    ("DirectSound", "cma_core::direct_sound::DirectSound"),
    ("FrameQuality", "cma_core::frame_quality::FrameQuality"),
    (
        "QualityMeasures",
        "cma_core::frame_quality::QualityMeasures",
    ),
    ("NoiseGate", "cma_core::noise_floor::NoiseGate"),
    ("FrameOnset", "cma_core::frame_onset::FrameOnset"),
    (
        "CapsuleCalibration",
        "cma_core::capsule_calibration::CapsuleCalibration",
    ),
    (
        "BackgroundField",
        "cma_core::background_field::BackgroundField",
    ),
    ("Combination", "cma_core::combination::Combination"),
    ("MultiTrack", "cma_core::multi_track::MultiTrack"),
    ("FdivSpread", "cma_core::combination::FdivSpread"),
    ("Smoothing", "cma_core::cartesian_filter::Smoothing"),
];

/// `config` as a Rust constant expression of type `cma_core::LocatorConfig`, every path absolute:
/// the file's form (`cma_core::config::ConfigFile`, every key as in the file) and its conversion.
pub fn to_rust(config: &LocatorConfig) -> Result<String, crate::ConfigError> {
    let mut w = Writer(String::new());
    config.serialize(&mut w).map_err(|e| crate::ConfigError {
        key: None,
        message: e.0,
    })?;
    Ok(format!("{}.into_config()", w.0))
}

/// Why a value could not be written as Rust.
#[derive(Debug)]
pub struct Unsupported(String);

impl fmt::Display for Unsupported {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Unsupported {}

impl ser::Error for Unsupported {
    fn custom<T: fmt::Display>(msg: T) -> Self {
        Unsupported(msg.to_string())
    }
}

fn path(name: &str) -> Result<&'static str, Unsupported> {
    PATHS
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, p)| *p)
        .ok_or_else(|| {
            Unsupported(format!(
                "the configuration type `{name}` has no path in cma-config's rust_code::PATHS"
            ))
        })
}

fn unsupported<T>(what: &str) -> Result<T, Unsupported> {
    Err(Unsupported(format!(
        "a configuration holds no {what}: cma-config's Rust writer does not write one"
    )))
}

struct Writer(String);

macro_rules! int {
    ($($f:ident: $t:ty),*) => {$(
        fn $f(self, v: $t) -> Result<(), Unsupported> {
            // No suffix: the literal takes the field's type (serde writes `usize` as `u64`).
            self.0.push_str(&v.to_string());
            Ok(())
        }
    )*};
}

impl<'a> ser::Serializer for &'a mut Writer {
    type Ok = ();
    type Error = Unsupported;
    type SerializeSeq = ser::Impossible<(), Unsupported>;
    type SerializeTuple = ser::Impossible<(), Unsupported>;
    type SerializeTupleStruct = ser::Impossible<(), Unsupported>;
    type SerializeTupleVariant = ser::Impossible<(), Unsupported>;
    type SerializeMap = ser::Impossible<(), Unsupported>;
    type SerializeStruct = Fields<'a>;
    type SerializeStructVariant = Fields<'a>;

    fn serialize_bool(self, v: bool) -> Result<(), Unsupported> {
        self.0.push_str(if v { "true" } else { "false" });
        Ok(())
    }
    int!(serialize_i8: i8, serialize_i16: i16, serialize_i32: i32, serialize_i64: i64,
         serialize_u8: u8, serialize_u16: u16, serialize_u32: u32, serialize_u64: u64);
    fn serialize_f32(self, v: f32) -> Result<(), Unsupported> {
        if !v.is_finite() {
            return unsupported("non-finite number");
        }
        // `{:?}` is the shortest text that parses back to the same f32, with a `.` or an exponent.
        self.0.push_str(&format!("{v:?}f32"));
        Ok(())
    }
    fn serialize_f64(self, v: f64) -> Result<(), Unsupported> {
        if !v.is_finite() {
            return unsupported("non-finite number");
        }
        self.0.push_str(&format!("{v:?}f64"));
        Ok(())
    }
    fn serialize_char(self, _: char) -> Result<(), Unsupported> {
        unsupported("character")
    }
    fn serialize_str(self, _: &str) -> Result<(), Unsupported> {
        unsupported("string")
    }
    fn serialize_bytes(self, _: &[u8]) -> Result<(), Unsupported> {
        unsupported("byte string")
    }
    fn serialize_none(self) -> Result<(), Unsupported> {
        unsupported("optional value")
    }
    fn serialize_some<T: ?Sized + Serialize>(self, _: &T) -> Result<(), Unsupported> {
        unsupported("optional value")
    }
    fn serialize_unit(self) -> Result<(), Unsupported> {
        unsupported("unit value")
    }
    fn serialize_unit_struct(self, name: &'static str) -> Result<(), Unsupported> {
        self.0.push_str(path(name)?);
        Ok(())
    }
    fn serialize_unit_variant(
        self,
        name: &'static str,
        _: u32,
        variant: &'static str,
    ) -> Result<(), Unsupported> {
        self.0.push_str(&format!("{}::{variant}", path(name)?));
        Ok(())
    }
    fn serialize_newtype_struct<T: ?Sized + Serialize>(
        self,
        name: &'static str,
        value: &T,
    ) -> Result<(), Unsupported> {
        self.0.push_str(&format!("{}(", path(name)?));
        value.serialize(&mut *self)?;
        self.0.push(')');
        Ok(())
    }
    fn serialize_newtype_variant<T: ?Sized + Serialize>(
        self,
        name: &'static str,
        _: u32,
        variant: &'static str,
        value: &T,
    ) -> Result<(), Unsupported> {
        self.0.push_str(&format!("{}::{variant}(", path(name)?));
        value.serialize(&mut *self)?;
        self.0.push(')');
        Ok(())
    }
    fn serialize_seq(self, _: Option<usize>) -> Result<Self::SerializeSeq, Unsupported> {
        unsupported("list")
    }
    fn serialize_tuple(self, _: usize) -> Result<Self::SerializeTuple, Unsupported> {
        unsupported("tuple")
    }
    fn serialize_tuple_struct(
        self,
        _: &'static str,
        _: usize,
    ) -> Result<Self::SerializeTupleStruct, Unsupported> {
        unsupported("tuple struct")
    }
    fn serialize_tuple_variant(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        _: usize,
    ) -> Result<Self::SerializeTupleVariant, Unsupported> {
        unsupported("tuple variant")
    }
    fn serialize_map(self, _: Option<usize>) -> Result<Self::SerializeMap, Unsupported> {
        unsupported("map")
    }
    fn serialize_struct(
        self,
        name: &'static str,
        _: usize,
    ) -> Result<Self::SerializeStruct, Unsupported> {
        self.0.push_str(&format!("{} {{ ", path(name)?));
        Ok(Fields(self))
    }
    fn serialize_struct_variant(
        self,
        name: &'static str,
        _: u32,
        variant: &'static str,
        _: usize,
    ) -> Result<Self::SerializeStructVariant, Unsupported> {
        self.0.push_str(&format!("{}::{variant} {{ ", path(name)?));
        Ok(Fields(self))
    }
}

/// The fields of a struct literal being written.
struct Fields<'a>(&'a mut Writer);

impl Fields<'_> {
    fn field<T: ?Sized + Serialize>(&mut self, key: &str, value: &T) -> Result<(), Unsupported> {
        self.0 .0.push_str(key);
        self.0 .0.push_str(": ");
        value.serialize(&mut *self.0)?;
        self.0 .0.push_str(", ");
        Ok(())
    }
}

impl ser::SerializeStruct for Fields<'_> {
    type Ok = ();
    type Error = Unsupported;
    fn serialize_field<T: ?Sized + Serialize>(
        &mut self,
        key: &'static str,
        value: &T,
    ) -> Result<(), Unsupported> {
        self.field(key, value)
    }
    fn end(self) -> Result<(), Unsupported> {
        self.0 .0.push('}');
        Ok(())
    }
}

impl ser::SerializeStructVariant for Fields<'_> {
    type Ok = ();
    type Error = Unsupported;
    fn serialize_field<T: ?Sized + Serialize>(
        &mut self,
        key: &'static str,
        value: &T,
    ) -> Result<(), Unsupported> {
        self.field(key, value)
    }
    fn end(self) -> Result<(), Unsupported> {
        self.0 .0.push('}');
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_struct_literals_with_typed_numbers_and_absolute_paths() {
        let code = to_rust(&LocatorConfig::thesis()).unwrap();
        assert!(
            code.starts_with(
                "cma_core::config::ConfigFile { method: cma_core::config::Method::Similarity, "
            ),
            "{code}"
        );
        assert!(code.contains("num_peaks: 10, "), "{code}");
        assert!(code.contains("silence_power: 1e-10f32, "), "{code}");
        assert!(
            code.contains("tracking: cma_core::config::Tracking::OnePole, "),
            "{code}"
        );
        let code = to_rust(&LocatorConfig::default()).unwrap();
        assert!(code.contains("tracking: cma_core::config::Tracking::Grid(cma_core::grid_tracker::GridTracker { sharpness: 60.0f32, "), "{code}");
        assert!(code.contains("kernel: cma_core::curve_kernel::CurveKernel::Distance { power: cma_core::refine_curve::DistancePower::ThreeHalves, scale: 1.5f32, }"), "{code}");
        assert!(code.ends_with(" }.into_config()"), "{code}");
        assert_eq!(code.matches('{').count(), code.matches('}').count());
    }
}
