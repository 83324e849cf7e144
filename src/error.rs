//! The crate's one error type: every way a blob, a calibration or a corrector request can be
//! refused, named by the phase that refuses it.

use core::fmt;

/// Which part of the calibration a validation error is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Field {
    /// `Environment::temperature_span`.
    TemperatureSpan,
    /// `Environment::voltage_span`.
    VoltageSpan,
    /// One of `Environment::temperatures`.
    TemperatureBreakpoint,
    /// One of `Environment::voltages`.
    VoltageBreakpoint,
    /// `Channel::center`.
    Center,
    /// `Channel::range`.
    InputRange,
    /// `AxisNonlinearity::quadratic`.
    Quadratic,
    /// `AxisNonlinearity::cubic`.
    Cubic,
    /// `AxisNonlinearity::odd_quadratic`.
    OddQuadratic,
    /// `AxisNonlinearity::asymmetry`.
    Asymmetry,
    /// `AxisNonlinearity::asymmetry_break`.
    AsymmetryBreak,
    /// `SingleSet::scale`.
    Scale,
    /// An offset (`SingleSet::offset`, `TriadSet::offset`).
    Offset,
    /// `TriadSet::matrix`.
    Matrix,
    /// `ImuSet::g_sensitivity`.
    GSensitivity,
    /// `Sensor::Imu::lever_arm`.
    LeverArm,
    /// A covariance factor.
    Covariance,
    /// The table of coefficient sets.
    Sets,
    /// The unit serial number.
    Serial,
    /// `NoiseTerms::white`.
    WhiteNoise,
    /// `NoiseTerms::bias_walk`.
    BiasWalk,
    /// `NoiseTerms::ageing_s`.
    Ageing,
    /// `NoiseTerms::gravity`.
    Gravity,
    /// `NoiseTerms::false_alarm`.
    FalseAlarm,
}

/// Which sensor of a calibration an error is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Part {
    /// The single axis, or the lone triad.
    Sensor,
    /// The IMU's accelerometer triad.
    Accelerometer,
    /// The IMU's gyro triad.
    Gyro,
}

/// Everything that can go wrong with a blob, a calibration or a corrector request.
///
/// The variants are named by the phase that raises them: `Header*` and `Length*` while the
/// fixed header is read, `Checksum*` before anything is decoded, `Payload*` while the postcard
/// payload is decoded, `Invalid*` while the decoded values are validated, `Encode*` while a
/// blob is written, `Corrector*` when a corrector is built, and `Health*` when the in-use
/// health check is set up.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Error {
    /// Fewer bytes than the fixed header.
    HeaderTruncated {
        /// Bytes found.
        found: usize,
    },
    /// The first four bytes are not the blob magic `SCAL`.
    HeaderBadMagic {
        /// The four bytes found.
        found: [u8; 4],
    },
    /// A format version this firmware does not know.
    HeaderUnsupportedVersion {
        /// Version byte found.
        found: u8,
    },
    /// Fewer bytes than the header declares.
    LengthTruncated {
        /// Bytes the header declares (header included).
        declared: usize,
        /// Bytes found.
        found: usize,
    },
    /// More bytes than the header declares.
    LengthTrailingBytes {
        /// Bytes the header declares (header included).
        declared: usize,
        /// Bytes found.
        found: usize,
    },
    /// The CRC-32C over header and payload does not match the stored one.
    ChecksumMismatch {
        /// CRC stored in the header.
        stored: u32,
        /// CRC computed over the bytes.
        computed: u32,
    },
    /// The payload passed its CRC but is not a well-formed calibration (a bad enum tag, a
    /// length running past the end, an invalid UTF-8 serial...).
    PayloadMalformed,
    /// The payload decodes but leaves bytes unread before the declared end.
    PayloadTrailingBytes {
        /// Bytes left unread.
        unread: usize,
    },
    /// A float that must be finite is NaN or infinite.
    InvalidNonFinite {
        /// The field.
        field: Field,
        /// The sensor it belongs to, if any.
        part: Option<Part>,
        /// The coefficient set (table index), if any.
        set: Option<u8>,
        /// The axis, breakpoint or element index, if any.
        index: Option<u8>,
    },
    /// More entries than the fixed capacity (`MAX_TEMPERATURES`, `MAX_VOLTAGES`, `MAX_SETS`,
    /// `SERIAL_CAPACITY`).
    InvalidCapacity {
        /// What overflowed.
        field: Field,
        /// The capacity.
        capacity: usize,
    },
    /// Table breakpoints not strictly increasing.
    InvalidBreakpointOrder {
        /// Temperature or voltage breakpoints.
        field: Field,
        /// Index of the first breakpoint not above its predecessor.
        index: u8,
    },
    /// A table breakpoint outside the calibrated span it belongs to.
    InvalidBreakpointOutsideSpan {
        /// Temperature or voltage breakpoints.
        field: Field,
        /// Index of the breakpoint.
        index: u8,
    },
    /// A span or range whose lower end is above its upper end.
    InvalidSpanOrder {
        /// Which span or range.
        field: Field,
        /// The sensor it belongs to, if any.
        part: Option<Part>,
        /// The axis, if any.
        index: Option<u8>,
    },
    /// The number of coefficient sets is not (temperature points) x (voltage points).
    InvalidTableShape {
        /// Sets required by the breakpoints.
        expected: usize,
        /// Sets found.
        found: usize,
    },
    /// ADC rails that leave no unsaturated code (`lo + 1 < hi` is required) or lie beyond
    /// their sample format's limits.
    InvalidRails {
        /// The sensor.
        part: Part,
    },
    /// An IMU whose gyro codes come in another sample format than its accelerometer's (one
    /// sample carries both).
    InvalidMixedFormats,
    /// A temperature series with no terms or more than the sets the device holds, alongside
    /// breakpoints, over a temperature span of zero width, or for an IMU with a lever arm
    /// (whose sensing directions are proven per set of a table).
    InvalidTemperatureSeries,
    /// An axis center (the zero-input code) not strictly inside the ADC rails.
    InvalidCenter {
        /// The sensor.
        part: Part,
        /// The axis.
        axis: u8,
    },
    /// A scale factor of zero or a scale-misalignment matrix that is singular (or nearly so).
    InvalidSingularMatrix {
        /// The sensor.
        part: Part,
        /// The coefficient set.
        set: u8,
    },
    /// A covariance table whose length differs from the number of coefficient sets.
    InvalidCovarianceIncomplete,
    /// A lever arm longer than `MAX_LEVER_ARM_M`.
    InvalidLeverArm {
        /// The accelerometer axis.
        axis: u8,
    },
    /// Coefficients so large that a sample inside the rails could produce an infinite output.
    InvalidUnboundedOutput {
        /// The sensor.
        part: Part,
        /// The coefficient set.
        set: u8,
    },
    /// An empty serial number or one with characters other than printable ASCII.
    InvalidSerial,
    /// The output buffer cannot hold the blob.
    EncodeBufferTooSmall {
        /// Bytes the buffer has.
        available: usize,
    },
    /// The calibration does not fit the format (the payload is longer than 65,535 bytes).
    EncodePayloadTooLong,
    /// The calibration is for another kind of sensor than the corrector.
    CorrectorWrongSensor,
    /// A sample rate that is not finite and positive, or above
    /// [`MAX_SAMPLE_RATE_HZ`](crate::model::MAX_SAMPLE_RATE_HZ).
    CorrectorBadSampleRate,
    /// A largest angular acceleration that is not finite and positive (rad/s^2).
    CorrectorBadAngularAcceleration,
    /// At this sample rate the g-sensitivity's feedback of the lever term (its tangential part
    /// grows with the rate) could grow the rate without bound for some code inside the rails.
    CorrectorUnboundedFeedback {
        /// The coefficient set with the largest loop gain.
        set: u8,
        /// The highest sample rate the calibration's feedback is bounded at (Hz, 0: none).
        max_rate_hz: u32,
    },
    /// With a lever arm, an accelerometer axis must sense mainly along itself: the diagonal of
    /// the inverse of its scale-misalignment matrix must dominate its row.
    InvalidSensingDirection {
        /// The coefficient set.
        set: u8,
        /// The accelerometer axis.
        axis: u8,
    },
    /// A noise term out of its bounds (see `NoiseTerms::validate`), or noise terms on a
    /// sensor that is not an IMU (`field` is then `Sets`).
    InvalidNoiseTerm {
        /// The term.
        field: Field,
        /// The output (`ax, ay, az, wx, wy, wz`), for per-output terms.
        index: Option<u8>,
    },
    /// The health check cannot run: the calibration carries no noise terms.
    HealthNoNoiseTerms,
    /// The health check cannot run: the calibration carries no covariance factors, so it
    /// states no prior for the biases.
    HealthNoCovariance,
    /// The calibration expects samples in another format than the corrector's.
    CorrectorWrongFormat {
        /// The format the calibration states.
        expected: crate::sample_format::SampleFormat,
        /// The corrector's sample format.
        found: crate::sample_format::SampleFormat,
    },
}

impl fmt::Display for Field {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let name = match self {
            Field::TemperatureSpan => "temperature span",
            Field::VoltageSpan => "voltage span",
            Field::TemperatureBreakpoint => "temperature breakpoint",
            Field::VoltageBreakpoint => "voltage breakpoint",
            Field::Center => "axis center",
            Field::InputRange => "calibrated input range",
            Field::Quadratic => "quadratic coefficient",
            Field::Cubic => "cubic coefficient",
            Field::OddQuadratic => "odd-quadratic coefficient",
            Field::Asymmetry => "asymmetry coefficient",
            Field::AsymmetryBreak => "asymmetry breakpoint",
            Field::Scale => "scale factor",
            Field::Offset => "offset",
            Field::Matrix => "scale-misalignment matrix",
            Field::GSensitivity => "g-sensitivity matrix",
            Field::LeverArm => "lever arm",
            Field::Covariance => "covariance factor",
            Field::Sets => "coefficient sets",
            Field::Serial => "serial number",
            Field::WhiteNoise => "white-noise density",
            Field::BiasWalk => "bias random walk",
            Field::Ageing => "ageing time",
            Field::Gravity => "gravity span",
            Field::FalseAlarm => "false-alarm rate",
        };
        f.write_str(name)
    }
}

impl fmt::Display for Part {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Part::Sensor => "sensor",
            Part::Accelerometer => "accelerometer",
            Part::Gyro => "gyro",
        })
    }
}

fn write_location(
    f: &mut fmt::Formatter<'_>,
    part: Option<Part>,
    set: Option<u8>,
    index: Option<u8>,
) -> fmt::Result {
    if let Some(part) = part {
        write!(f, " of the {part}")?;
    }
    if let Some(set) = set {
        write!(f, " in coefficient set {set}")?;
    }
    if let Some(index) = index {
        write!(f, " at index {index}")?;
    }
    Ok(())
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Error::HeaderTruncated { found } => {
                write!(f, "blob has {found} bytes, fewer than the 11-byte header")
            }
            Error::HeaderBadMagic { found } => {
                write!(f, "blob magic is {found:02x?}, expected \"SCAL\"")
            }
            Error::HeaderUnsupportedVersion { found } => write!(
                f,
                "blob format version {found} is not supported (this firmware reads version {})",
                crate::limits::FORMAT_VERSION
            ),
            Error::LengthTruncated { declared, found } => {
                write!(
                    f,
                    "blob declares {declared} bytes but only {found} are present"
                )
            }
            Error::LengthTrailingBytes { declared, found } => write!(
                f,
                "blob declares {declared} bytes but {found} are present (trailing bytes)"
            ),
            Error::ChecksumMismatch { stored, computed } => write!(
                f,
                "blob CRC-32C mismatch: stored {stored:#010x}, computed {computed:#010x}"
            ),
            Error::PayloadMalformed => f.write_str("blob payload is not a well-formed calibration"),
            Error::PayloadTrailingBytes { unread } => {
                write!(f, "blob payload leaves {unread} bytes unread")
            }
            Error::InvalidNonFinite {
                field,
                part,
                set,
                index,
            } => {
                write!(f, "{field}")?;
                write_location(f, part, set, index)?;
                f.write_str(" is not finite")
            }
            Error::InvalidCapacity { field, capacity } => {
                write!(f, "{field}: more than the capacity of {capacity}")
            }
            Error::InvalidBreakpointOrder { field, index } => {
                write!(f, "{field} {index} is not above the one before it")
            }
            Error::InvalidBreakpointOutsideSpan { field, index } => {
                write!(f, "{field} {index} lies outside the calibrated span")
            }
            Error::InvalidSpanOrder { field, part, index } => {
                write!(f, "{field}")?;
                write_location(f, part, None, index)?;
                f.write_str(" has its lower end above its upper end")
            }
            Error::InvalidTableShape { expected, found } => write!(
                f,
                "the breakpoints need {expected} coefficient sets but {found} are present"
            ),
            Error::InvalidRails { part } => {
                write!(
                    f,
                    "the ADC rails of the {part} leave no unsaturated code or lie beyond \
                     their sample format"
                )
            }
            Error::InvalidMixedFormats => f.write_str(
                "the gyro's codes come in another sample format than the accelerometer's",
            ),
            Error::InvalidTemperatureSeries => f.write_str(
                "the temperature series has no terms or too many, comes with breakpoints, \
                 spans no temperatures, or is an IMU's with a lever arm (a table is needed)",
            ),
            Error::InvalidCenter { part, axis } => write!(
                f,
                "the center of {part} axis {axis} is not strictly inside its ADC rails"
            ),
            Error::InvalidSingularMatrix { part, set } => write!(
                f,
                "the scale of the {part} in coefficient set {set} is singular"
            ),
            Error::InvalidCovarianceIncomplete => {
                f.write_str("the covariance table does not have one factor per coefficient set")
            }
            Error::InvalidLeverArm { axis } => write!(
                f,
                "the lever arm of accelerometer axis {axis} is longer than {} m",
                crate::limits::MAX_LEVER_ARM_M
            ),
            Error::InvalidUnboundedOutput { part, set } => write!(
                f,
                "the coefficients of the {part} in coefficient set {set} can overflow \
                 single precision inside the ADC rails"
            ),
            Error::InvalidSerial => {
                f.write_str("the serial number is empty or not printable ASCII")
            }
            Error::EncodeBufferTooSmall { available } => {
                write!(
                    f,
                    "the output buffer of {available} bytes cannot hold the blob"
                )
            }
            Error::EncodePayloadTooLong => {
                f.write_str("the calibration payload is longer than 65,535 bytes")
            }
            Error::CorrectorWrongSensor => {
                f.write_str("the calibration is for another kind of sensor than this corrector")
            }
            Error::CorrectorUnboundedFeedback { set, max_rate_hz } => write!(
                f,
                "at this sample rate the g-sensitivity's feedback of the lever term (coefficient \
                 set {set}) is not bounded inside the ADC rails: the calibration corrects at up \
                 to {max_rate_hz} Hz"
            ),
            Error::CorrectorBadSampleRate => write!(
                f,
                "the sample rate must be finite, positive and at most {} Hz",
                crate::limits::MAX_SAMPLE_RATE_HZ
            ),
            Error::CorrectorBadAngularAcceleration => f.write_str(
                "the largest angular acceleration must be finite and positive (rad/s^2)",
            ),
            Error::InvalidSensingDirection { set, axis } => write!(
                f,
                "accelerometer axis {axis} in coefficient set {set} does not sense mainly \
                 along itself, so its lever arm cannot be removed"
            ),
            Error::InvalidNoiseTerm {
                field: Field::Sets, ..
            } => f.write_str("noise terms are only for an IMU calibration"),
            Error::InvalidNoiseTerm { field, index } => {
                write!(f, "the {field}")?;
                if let Some(i) = index {
                    let name = ["ax", "ay", "az", "wx", "wy", "wz"];
                    write!(f, " of output {}", name.get(usize::from(i)).unwrap_or(&"?"))?;
                }
                f.write_str(
                    " is out of bounds (densities positive, walks and ageing non-negative, \
                     gravity within 9.7..9.9 m/s^2, false-alarm rate in (0, 0.5])",
                )
            }
            Error::HealthNoNoiseTerms => f.write_str(
                "the health check cannot run: the calibration has no noise terms \
                 (calflash calibrate --noise-terms); the unit still corrects",
            ),
            Error::HealthNoCovariance => f.write_str(
                "the health check cannot run: the calibration has no covariance factors, so \
                 it states no prior for the biases; the unit still corrects",
            ),
            Error::CorrectorWrongFormat { expected, found } => write!(
                f,
                "the calibration expects {} samples; this corrector takes {}",
                expected.name(),
                found.name()
            ),
        }
    }
}

impl core::error::Error for Error {}
