//! What the error-state filter estimates: the navigation and the corrected samples' residual
//! sensor errors, and the error that takes one estimate to another.

use nalgebra::{RealField, Vector3};

use super::filter::{StateVector, index};
use super::real::{Real, rotation};
use super::strapdown::Navigation;

/// The residual errors of the corrected samples and the barometer, as estimated.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorErrors<T: RealField + Copy> {
    /// Accelerometer biases, m/s^2.
    pub accel_bias: Vector3<T>,
    /// Gyro biases, rad/s.
    pub gyro_bias: Vector3<T>,
    /// Accelerometer scale factors (relative: 0.001 reads 0.1 % high).
    pub accel_scale: Vector3<T>,
    /// Gyro scale factors.
    pub gyro_scale: Vector3<T>,
    /// The barometer's height bias, m.
    pub baro_bias: T,
}

impl<T: RealField + Copy> Default for SensorErrors<T> {
    fn default() -> Self {
        Self {
            accel_bias: Vector3::zeros(),
            gyro_bias: Vector3::zeros(),
            accel_scale: Vector3::zeros(),
            gyro_scale: Vector3::zeros(),
            baro_bias: T::zero(),
        }
    }
}

impl<T: RealField + Copy> SensorErrors<T> {
    /// A corrected sample with these errors taken out: `(f - b) / (1 + s)` per axis.
    #[must_use]
    pub fn compensate(&self, f: &Vector3<T>, w: &Vector3<T>) -> (Vector3<T>, Vector3<T>) {
        let one = Vector3::repeat(T::one());
        (
            (f - self.accel_bias).component_div(&(one + self.accel_scale)),
            (w - self.gyro_bias).component_div(&(one + self.gyro_scale)),
        )
    }
}

/// The navigation and the sensor errors together: what the filter estimates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate<T: RealField + Copy> {
    /// The navigation.
    pub nav: Navigation<T>,
    /// The sensor errors.
    pub sensors: SensorErrors<T>,
    /// The GNSS receiver's correlated position error (east, north, up, m): what its fixes
    /// hold beside the antenna's position and their white noise, a first-order Gauss-Markov
    /// process ([`NavNoise::receiver_sigma`](super::NavNoise::receiver_sigma)); zero while
    /// nothing has told the filter otherwise.
    pub receiver: Vector3<T>,
}

fn block<T: RealField + Copy>(x: &StateVector<T>, at: usize) -> Vector3<T> {
    x.fixed_rows::<3>(at).into_owned()
}

impl<T: Real> Estimate<T> {
    /// This estimate corrected by the error `dx`.
    #[must_use]
    pub fn plus(&self, dx: &StateVector<T>) -> Self {
        let mut out = *self;
        out.correct(dx);
        out
    }

    /// Corrects this estimate by the error `dx`, in place.
    pub fn correct(&mut self, dx: &StateVector<T>) {
        use index::*;
        self.nav.p += block(dx, POSITION);
        self.nav.v += block(dx, VELOCITY);
        self.nav.turn(&rotation(&block(dx, ATTITUDE)));
        self.sensors.accel_bias += block(dx, ACCEL_BIAS);
        self.sensors.gyro_bias += block(dx, GYRO_BIAS);
        self.sensors.accel_scale += block(dx, ACCEL_SCALE);
        self.sensors.gyro_scale += block(dx, GYRO_SCALE);
        self.sensors.baro_bias += dx.get(BARO).copied().unwrap_or_else(T::zero);
        self.receiver += block(dx, RECEIVER);
    }

    /// The error that takes `other` to this estimate (`self = other.plus(dx)`).
    #[must_use]
    pub fn minus(&self, other: &Self) -> StateVector<T> {
        use index::*;
        let mut dx = StateVector::zeros();
        let (a, b) = (&self.sensors, &other.sensors);
        let parts = [
            (POSITION, self.nav.p - other.nav.p),
            (VELOCITY, self.nav.v - other.nav.v),
            (
                ATTITUDE,
                (self.nav.attitude() * other.nav.attitude().inverse()).scaled_axis(),
            ),
            (ACCEL_BIAS, a.accel_bias - b.accel_bias),
            (GYRO_BIAS, a.gyro_bias - b.gyro_bias),
            (ACCEL_SCALE, a.accel_scale - b.accel_scale),
            (GYRO_SCALE, a.gyro_scale - b.gyro_scale),
            (RECEIVER, self.receiver - other.receiver),
        ];
        for (at, v) in parts {
            dx.fixed_rows_mut::<3>(at).copy_from(&v);
        }
        if let Some(x) = dx.get_mut(BARO) {
            *x = a.baro_bias - b.baro_bias;
        }
        dx
    }
}
