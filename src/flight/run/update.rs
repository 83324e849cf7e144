//! The filter's measurement updates at an epoch: a GNSS fix's antenna position and velocity
//! (predicted back at the fix's instant), the barometer's height, each gated on its
//! innovation and counted in the flight's statistics.

use nalgebra::Vector3;

use super::{FlightFilter, GnssFix, LOST_VELOCITY, c, micros};
use crate::flight::air;
use crate::flight::origin::Origin;
use crate::flight::stats::Aiding;
use crate::nav::{ErrorFilter, Real};

impl<T: Real> FlightFilter<T> {
    pub(super) fn gnss_update(&mut self, fix: &GnssFix, origin: &Origin, t_us: u64) {
        let z = origin.local(&fix.position);
        // The fix describes an instant before this one: move the prediction back to it.
        let back: T = micros(t_us.saturating_sub(fix.t_us));
        let (h_sigma, v_sigma) = self.config.gnss_sigma;
        let lever = self.config.lever;
        let velocity_lost = self.filter.velocity_lost(c::<T>(LOST_VELOCITY));
        // The receiver's east, north, up at its own position, in the level frame.
        let velocity = fix
            .velocity
            .map(|v| origin.level_velocity(&fix.position, &v));
        if let (true, Some(vel)) = (velocity_lost, velocity) {
            let v = Vector3::new(c(vel[0]), c(vel[1]), c(vel[2]));
            let arm = self.filter.estimate.nav.attitude() * lever;
            // Put back at this epoch: the fix's position carried forward by its velocity,
            // its velocity by the navigation's rate of change since.
            let at = Vector3::new(c::<T>(z[0]), c(z[1]), c(z[2])) + v * back - arm;
            let v = v + self.pace.1 * back;
            let r = self.config.gnss_velocity_sigma;
            let (h2, v2, r2) = (h_sigma * h_sigma, v_sigma * v_sigma, r * r);
            self.filter
                .reset_position_velocity(&at, &v, [h2, h2, v2, r2, r2, r2]);
            self.stats.navigation_resets += 1;
            return;
        }
        // The antenna `back` ago: moved back by the velocity now less the half of the
        // navigation's rate of change over the age (a shell decelerating at 5 g is 0.16 m
        // from the linear guess after 80 ms, twice the track's 1-sigma).
        let half: T = c(0.5);
        for (axis, zi) in z.iter().enumerate() {
            let (h, at) = self.filter.fix_row_back(&lever, axis, back);
            let v = self.velocity(axis);
            let a = self.pace.1.get(axis).copied().unwrap_or_else(T::zero);
            let r = if axis == 2 { v_sigma } else { h_sigma };
            let then = at - v * back + half * a * back * back;
            self.take(Aiding::Position, &h, c::<T>(*zi) - then, r * r);
        }
        if let Some(vel) = velocity {
            let r = self.config.gnss_velocity_sigma;
            // The navigation's velocity at the fix's instant, `back` ago.
            let then = self.pace.1 * back;
            for (axis, vi) in vel.iter().enumerate() {
                let earlier = then.get(axis).copied().unwrap_or_else(T::zero);
                let nu = c::<T>(*vi) + earlier - self.velocity(axis);
                // The errors then, through their rates over the fix's age (the attitude's
                // through the specific force). Where that term's own variance is beyond the
                // fix's (the navigation just put back after a saturated setback, its attitude
                // tenths of a radian off), the linear model is not to be trusted to learn the
                // attitude from 80 ms: the term widens the fix's variance instead.
                let now = ErrorFilter::velocity_row(axis);
                let delayed = self.filter.velocity_row_back(axis, back);
                let d = delayed - now;
                let lag = d.dot(&(self.filter.covariance * d));
                if lag <= r * r {
                    self.take(Aiding::Velocity, &delayed, nu, r * r);
                } else {
                    self.take(Aiding::Velocity, &now, nu, r * r + lag);
                }
            }
        }
    }

    pub(super) fn baro_update(&mut self, t_us: u64, pa: T, reference: T) {
        let nav = &self.filter.estimate.nav;
        let height = c::<T>(self.origin.map_or(0.0, |o| o.geodetic().height)) + nav.p.z;
        let v2 = nav.v.norm_squared();
        let sound = air::speed_of_sound(height);
        if v2 >= (self.config.baro_mach * sound).powi(2) {
            self.stats.baro_transonic += 1;
            return;
        }
        self.last_baro_us = Some(t_us);
        let z = air::pressure_height(pa) - reference;
        let (h, at) = self.filter.baro_row();
        let port = self.config.baro_cp * v2 / c(2.0 * air::G0);
        let r2 = self.config.baro_sigma * self.config.baro_sigma + port * port;
        self.take(Aiding::Baro, &h, z - at, r2);
    }

    /// The navigation's velocity along the level-frame axis `axis`, m/s.
    fn velocity(&self, axis: usize) -> T {
        self.filter
            .estimate
            .nav
            .v
            .get(axis)
            .copied()
            .unwrap_or_else(T::zero)
    }

    /// Gates and takes a measured velocity along `axis` of variance `r2`.
    pub(super) fn take_velocity(&mut self, kind: Aiding, axis: usize, measured: T, r2: T) {
        let h = ErrorFilter::velocity_row(axis);
        let nu = measured - self.velocity(axis);
        self.take(kind, &h, nu, r2);
    }

    /// Gates and takes one scalar measurement.
    pub(super) fn take(&mut self, kind: Aiding, h: &crate::nav::StateVector<T>, nu: T, r2: T) {
        let peek = self.filter.innovation(h, nu, r2);
        let k = kind as usize;
        let inside = peek.value * peek.value <= self.config.gate * self.config.gate * peek.variance;
        let within_95 = peek.value * peek.value <= c::<T>(1.96 * 1.96) * peek.variance;
        if let (true, Some(n)) = (within_95, self.stats.inside.get_mut(k)) {
            *n += 1;
        }
        let taken = inside && self.filter.update(h, nu, r2).is_some();
        let (count, nis) = if taken {
            (
                self.stats.taken.get_mut(k),
                (peek.value * peek.value / peek.variance).to_f64(),
            )
        } else {
            (self.stats.refused.get_mut(k), 0.0)
        };
        if let Some(n) = count {
            *n += 1;
        }
        if let Some(s) = self.stats.nis.get_mut(k) {
            *s += nis as f32;
        }
    }
}
