//! What a calibration is: the correction coefficients of a single axis, a triad or an IMU,
//! tabulated over temperature and supply voltage, with the calibrated ranges, the ADC rails and
//! the unit's identity.
//!
//! # The correction, per sample
//!
//! Raw counts `r` come in; SI values come out (m/s^2 for acceleration, rad/s for angular rate).
//! For every axis, with `c` the axis [`Channel::center`] (the code at zero input):
//!
//! ```text
//! v = r - c                                                  counts from the zero-input code
//! u = v + q v^2 + k v^3 + o v|v| + s |v - b|                 AxisNonlinearity (q, k, o, s, b)
//! ```
//!
//! `u` is the linearised output in counts. The asymmetry term `s |v - b|` gives the axis the
//! slopes `1 + s` above the breakpoint `b` and `1 - s` below it (an asymmetric scale factor).
//! Then, per sensor:
//!
//! - single axis: `y = offset + scale * u` ([`SingleSet`]);
//! - triad: `y = M u + offset` with `M` the 3x3 scale-misalignment matrix, row-major
//!   ([`TriadSet`]): `M` holds the scale factors (SI units per count) on its diagonal and the
//!   misalignment off it; `offset = -M b` for a bias `b` in counts;
//! - IMU: the accelerometer triad gives the sensor-domain specific force `a`; the gyro triad
//!   gives `w = M_g u_g + offset_g - G f` with `G` the g-sensitivity (rad/s per m/s^2,
//!   [`ImuSet`]) acting on the specific force at the reference point `f`; each accelerometer
//!   axis `i` sits at `r_i` from the reference point (the rows of [`Sensor::Imu::lever_arm`],
//!   metres, body frame), and `f = a - e(w, dw/dt)` removes what each axis sensed of the
//!   centripetal and tangential accelerations at its position, with `dw/dt` the backward
//!   difference of `w` at the corrector's sample rate. [`rotation`] writes the model under
//!   rotation out in full, forward and inverse.
//!
//! The coefficient sets are tabulated at temperature breakpoints and/or voltage breakpoints
//! ([`Environment`]); the device interpolates them linearly (bilinearly when both tables are
//! present) and clamps to the table's edges outside it, flagging every sample.

mod bounded;
pub mod examples;
pub(crate) mod interval;
mod noise;
pub mod rotation;
mod series;
mod sets;
pub(crate) mod validate;

pub use bounded::{BoundedVec, Serial};
pub use noise::{IMU_OUTPUTS, MAX_AGEING_S, NoiseTerms};
pub(crate) use sets::Blend;
pub use sets::{
    AxisNonlinearity, IMU_FEATURES, ImuCovariance, ImuOutputCovariance, ImuSet, SingleCovariance,
    SingleSet, TriadCovariance, TriadSet,
};

use ref_cast::{RefCastCustom, ref_cast_custom};
use serde::{Deserialize, Serialize};

use crate::Error;

/// Most temperature breakpoints a table can have.
pub const MAX_TEMPERATURES: usize = 16;
/// Most voltage breakpoints a table can have.
pub const MAX_VOLTAGES: usize = 8;
/// Most coefficient sets a calibration can hold (temperature points x voltage points).
pub const MAX_SETS: usize = 16;
/// Longest serial number, in bytes.
pub const SERIAL_CAPACITY: usize = 16;
pub use crate::limits::{MAX_LEVER_ARM_M, MAX_SAMPLE_RATE_HZ};
pub use crate::sample_format::SampleFormat;

/// The physical quantity a sensor measures, and so the unit of its corrected output.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Quantity {
    /// Specific force, m/s^2.
    Acceleration,
    /// Angular rate, rad/s.
    AngularRate,
}

/// A closed interval `[lo, hi]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Span {
    /// Lower end.
    pub lo: f32,
    /// Upper end.
    pub hi: f32,
}

impl Span {
    /// The interval `[lo, hi]`.
    #[must_use]
    pub const fn new(lo: f32, hi: f32) -> Self {
        Self { lo, hi }
    }

    /// True when `x` lies in `[lo, hi]` (false for NaN).
    #[must_use]
    pub fn contains(&self, x: f32) -> bool {
        self.lo <= x && x <= self.hi
    }
}

/// The converter's codes: the container they come in and the ADC's limits. A sample at or
/// beyond a rail (`raw <= lo` or `raw >= hi`) is saturated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Rails {
    /// Lowest code; codes at or below it are saturated.
    pub lo: i32,
    /// Highest code; codes at or above it are saturated.
    pub hi: i32,
    /// The container the samples come in; `lo` and `hi` lie within its limits.
    pub format: SampleFormat,
}

impl Rails {
    /// The rails `lo` and `hi` in the smallest container that holds them: `u16` when both
    /// lie in `0..=65535`, else `i16` when both lie in `-32768..=32767`, else `i32`.
    #[must_use]
    pub const fn new(lo: i32, hi: i32) -> Self {
        let format = if lo >= 0 && hi <= u16::MAX as i32 {
            SampleFormat::U16
        } else if lo >= i16::MIN as i32 && hi <= i16::MAX as i32 {
            SampleFormat::I16
        } else {
            SampleFormat::I32
        };
        Self { lo, hi, format }
    }

    /// The rails of an unsigned `bits`-bit converter (`bits` from 1 to 31): `0` and
    /// `2^bits - 1`, in `u16` up to 16 bits and `i32` above.
    #[must_use]
    pub const fn unsigned(bits: u32) -> Self {
        Self::new(0, ((1i64 << bits) - 1) as i32)
    }

    /// The rails of a signed (two's-complement) `bits`-bit converter (`bits` from 2 to 32):
    /// `-2^(bits-1)` and `2^(bits-1) - 1`, in `i16` up to 16 bits and `i32` above.
    #[must_use]
    pub const fn signed(bits: u32) -> Self {
        let half = 1i64 << (bits - 1);
        Self::new(-half as i32, (half - 1) as i32)
    }

    /// The same rails for samples delivered in `format` (a 12-bit unsigned converter read
    /// into `i16`, say). Validation refuses rails beyond the container's limits.
    #[must_use]
    pub const fn in_format(self, format: SampleFormat) -> Self {
        Self { format, ..self }
    }

    /// True when `raw` is at or beyond a rail.
    #[must_use]
    pub const fn saturated(&self, raw: i32) -> bool {
        raw <= self.lo || raw >= self.hi
    }
}

/// What does not change with temperature or voltage for one axis.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Channel {
    /// The code at zero input (counts); the origin of the axis nonlinearity.
    pub center: f32,
    /// The calibrated input range (SI units): corrected values outside it are flagged.
    pub range: Span,
}

impl Channel {
    /// The axis' `v` (code less its centre) at the two rails.
    pub(crate) fn rail_offsets(&self, rails: &Rails) -> (f32, f32) {
        (rails.lo as f32 - self.center, rails.hi as f32 - self.center)
    }
}

/// The calibrated temperature and voltage spans, and the breakpoints of the coefficient table.
///
/// The table holds `nt x nv` coefficient sets, `nt = max(1, temperatures.len())` and
/// `nv = max(1, voltages.len())`, stored temperature-major: set `t * nv + v` belongs to
/// temperature breakpoint `t` and voltage breakpoint `v`. With no breakpoints of a kind the
/// coefficients do not depend on that quantity; its span is still checked and flagged.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Environment {
    /// Calibrated temperature span, degrees Celsius.
    pub temperature_span: Span,
    /// Calibrated supply-voltage span, volts.
    pub voltage_span: Span,
    /// Temperature breakpoints, strictly increasing, inside `temperature_span`.
    pub temperatures: BoundedVec<f32, MAX_TEMPERATURES>,
    /// Voltage breakpoints, strictly increasing, inside `voltage_span`.
    pub voltages: BoundedVec<f32, MAX_VOLTAGES>,
    /// How the sets follow the temperature: a table at `temperatures`, or a series over
    /// `temperature_span`.
    pub temperature_model: TemperatureModel,
}

/// How the coefficient sets follow the temperature.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum TemperatureModel {
    /// One set per temperature breakpoint, blended linearly between them (one set when there
    /// are no breakpoints).
    Table,
    /// A Chebyshev series of this many terms over the calibrated temperature span: the sets (per
    /// voltage point) are the coefficients of `T_0(x) ... T_(n-1)(x)`,
    /// `x = (T - mid) / half` clamped to [-1, 1], summed by Clenshaw's recurrence. The
    /// breakpoint list is empty. Single-axis calibrations only.
    Chebyshev(u8),
}

impl Environment {
    /// A calibration made at one temperature and voltage span with no table.
    #[must_use]
    pub const fn fixed(temperature_span: Span, voltage_span: Span) -> Self {
        Self {
            temperature_span,
            voltage_span,
            temperatures: BoundedVec::new(),
            voltages: BoundedVec::new(),
            temperature_model: TemperatureModel::Table,
        }
    }

    /// Temperature points of the table (at least 1).
    #[must_use]
    pub fn temperature_points(&self) -> usize {
        match self.temperature_model {
            TemperatureModel::Table => self.temperatures.len().max(1),
            TemperatureModel::Chebyshev(n) => usize::from(n),
        }
    }

    /// Voltage points of the table (at least 1).
    #[must_use]
    pub fn voltage_points(&self) -> usize {
        self.voltages.len().max(1)
    }
}

/// Where a calibration came from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Identity {
    /// The unit's serial number.
    pub serial: Serial,
    /// When the calibration was made, seconds since 1970-01-01 UTC.
    pub created_unix_s: u64,
    /// The first 16 bytes of the SHA-256 of the observation data the fit used.
    pub data_hash: [u8; 16],
    /// Version (major, minor, patch) of the tool that made the calibration.
    pub tool_version: [u16; 3],
    /// The fit behind it was judged REJECT and the blob written all the same
    /// (`calflash calibrate --force-blob`): a flasher refuses it unless told otherwise.
    pub fit_rejected: bool,
}

/// The sensor, its fixed per-axis data, and its table of coefficient sets.
#[expect(
    clippy::large_enum_variant,
    reason = "no allocator on the device: a calibration is one fixed-size value"
)]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Sensor {
    /// One axis.
    Single {
        /// What it measures.
        quantity: Quantity,
        /// ADC rails.
        rails: Rails,
        /// Zero-input code and calibrated range.
        channel: Channel,
        /// One set per table point.
        sets: BoundedVec<SingleSet, MAX_SETS>,
        /// Optional covariance factors, one per set.
        covariance: Option<BoundedVec<SingleCovariance, MAX_SETS>>,
    },
    /// Three axes of one quantity (an accelerometer or a gyro triad).
    Triad {
        /// What it measures.
        quantity: Quantity,
        /// ADC rails, shared by the three axes.
        rails: Rails,
        /// Per axis: zero-input code and calibrated range.
        channels: [Channel; 3],
        /// One set per table point.
        sets: BoundedVec<TriadSet, MAX_SETS>,
        /// Optional covariance factors, one per set.
        covariance: Option<BoundedVec<TriadCovariance, MAX_SETS>>,
    },
    /// An accelerometer triad and a gyro triad sampled together.
    Imu {
        /// Accelerometer ADC rails.
        accel_rails: Rails,
        /// Gyro ADC rails.
        gyro_rails: Rails,
        /// Accelerometer axes.
        accel: [Channel; 3],
        /// Gyro axes.
        gyro: [Channel; 3],
        /// Row `i`: position of accelerometer axis `i` from the reference point, metres, body
        /// frame. `None`: no size-effect correction.
        lever_arm: Option<[[f32; 3]; 3]>,
        /// One set per table point.
        sets: BoundedVec<ImuSet, MAX_SETS>,
        /// Optional covariance factors, one per set.
        covariance: Option<BoundedVec<ImuCovariance, MAX_SETS>>,
    },
}

impl Sensor {
    /// The rails of its codes (the accelerometer's for an IMU).
    #[must_use]
    pub const fn rails(&self) -> Rails {
        match self {
            Sensor::Single { rails, .. } | Sensor::Triad { rails, .. } => *rails,
            Sensor::Imu { accel_rails, .. } => *accel_rails,
        }
    }

    /// The sample format its codes come in (for an IMU, validation makes the gyro's the same
    /// as the accelerometer's).
    #[must_use]
    pub const fn sample_format(&self) -> SampleFormat {
        self.rails().format
    }

    /// Number of coefficient sets.
    #[must_use]
    pub fn set_count(&self) -> usize {
        match self {
            Sensor::Single { sets, .. } => sets.len(),
            Sensor::Triad { sets, .. } => sets.len(),
            Sensor::Imu { sets, .. } => sets.len(),
        }
    }
}

/// A calibration as plain data: what the blob carries. Build one, then validate it with
/// [`Calibration::new`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CalibrationData {
    /// Where it came from.
    pub identity: Identity,
    /// Calibrated spans and table breakpoints.
    pub environment: Environment,
    /// The sensor and its coefficients.
    pub sensor: Sensor,
    /// The IMU's noise terms and the allowances of its health check at rest
    /// ([`crate::health`]); `None`: the unit corrects but does not judge its calibration.
    pub noise: Option<NoiseTerms>,
}

impl CalibrationData {
    /// A placeholder to decode into (see [`crate::blob::decode_in`]): an empty serial and no
    /// coefficient sets, so it does not validate.
    #[must_use]
    pub const fn empty() -> Self {
        Self {
            identity: Identity {
                serial: Serial::EMPTY,
                created_unix_s: 0,
                data_hash: [0; 16],
                tool_version: [0; 3],
                fit_rejected: false,
            },
            environment: Environment::fixed(Span::new(0.0, 0.0), Span::new(0.0, 0.0)),
            sensor: Sensor::Single {
                quantity: Quantity::Acceleration,
                rails: Rails::new(0, 0),
                channel: Channel {
                    center: 0.0,
                    range: Span::new(0.0, 0.0),
                },
                sets: BoundedVec::new(),
                covariance: None,
            },
            noise: None,
        }
    }
}

/// A validated calibration: every float finite, breakpoints strictly increasing, table shape
/// and capacities right, matrices invertible, outputs bounded inside the rails. The only ways
/// to get one are [`Calibration::new`], [`Calibration::validate_in_place`],
/// [`crate::blob::decode`] and [`crate::blob::decode_in`].
#[derive(Debug, Clone, PartialEq, RefCastCustom)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(transparent)]
pub struct Calibration {
    data: CalibrationData,
}

impl Calibration {
    /// Validates `data`.
    ///
    /// # Errors
    /// The first `Invalid*` [`Error`] found.
    pub fn new(data: CalibrationData) -> Result<Self, Error> {
        validate::validate(&data)?;
        Ok(Self { data })
    }

    /// Validates `data` where it lies and, when it passes, views it as a calibration, with no
    /// copy (for a calibration kept in a `static` on the device).
    ///
    /// # Errors
    /// The first `Invalid*` [`Error`] found.
    pub fn validate_in_place(data: &CalibrationData) -> Result<&Self, Error> {
        validate::validate(data)?;
        Ok(Self::view(data))
    }

    #[ref_cast_custom]
    const fn view(data: &CalibrationData) -> &Self;

    /// Wraps data that has just passed validation.
    pub(crate) const fn validated(data: CalibrationData) -> Self {
        Self { data }
    }

    /// The validated data.
    #[must_use]
    pub const fn data(&self) -> &CalibrationData {
        &self.data
    }

    /// Gives the data back.
    #[must_use]
    pub fn into_data(self) -> CalibrationData {
        self.data
    }

    /// The highest sample rate (Hz, to 1 %) a corrector of this calibration can run at:
    /// [`MAX_SAMPLE_RATE_HZ`] but for an IMU with a lever arm whose g-sensitivity feeds the
    /// lever term's tangential part (which grows with the rate) back into the rates strongly
    /// enough to grow them without bound above it.
    #[must_use]
    pub fn max_sample_rate_hz(&self) -> f32 {
        self.feedback().map_or(MAX_SAMPLE_RATE_HZ, |f| f.max_rate())
    }

    /// The g-sensitivity's feedback of an IMU's lever term, when it has a lever arm.
    pub(crate) fn feedback(&self) -> Option<validate::Feedback> {
        let Sensor::Imu {
            accel_rails,
            gyro_rails,
            accel,
            gyro,
            lever_arm: Some(arm),
            sets,
            ..
        } = &self.data.sensor
        else {
            return None;
        };
        validate::Feedback::of(sets, arm, (accel, accel_rails), (gyro, gyro_rails)).ok()
    }
}
