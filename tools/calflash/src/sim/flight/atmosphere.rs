//! The ICAO standard atmosphere (ISO 2533) to 32 km: a troposphere cooling at 6.5 K/km to
//! 11 km, an isothermal layer to 20 km, then warming at 1 K/km.

/// Standard gravity, m/s^2 (the atmosphere's geopotential unit and the flights' gravity).
pub const G0: f64 = 9.806_65;
/// The gas constant of dry air, J/(kg K).
const R: f64 = 287.052_87;
/// The ratio of specific heats of air.
const GAMMA: f64 = 1.4;

/// The air at one height.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Air {
    /// Density, kg/m^3.
    pub density: f64,
    /// Speed of sound, m/s.
    pub sound: f64,
    /// Temperature, K.
    pub temperature: f64,
    /// Pressure, Pa.
    pub pressure: f64,
}

/// The layers: base height (m), base temperature (K), lapse rate (K/m), base pressure (Pa).
const LAYERS: [(f64, f64, f64, f64); 3] = [
    (0.0, 288.15, -0.0065, 101_325.0),
    (11_000.0, 216.65, 0.0, 22_632.06),
    (20_000.0, 216.65, 0.001, 5_474.889),
];

/// The Earth's radius the standard atmosphere's geopotential uses, m.
const EARTH_RADIUS: f64 = 6_356_766.0;

/// The standard atmosphere at height `z` m above sea level (geometric; clamped to -1 km ..
/// 32 km of geopotential height).
#[must_use]
pub fn standard(z: f64) -> Air {
    let h = (EARTH_RADIUS * z / (EARTH_RADIUS + z)).clamp(-1_000.0, 32_000.0);
    let (base, t0, lapse, p0) = LAYERS
        .iter()
        .rev()
        .find(|l| h >= l.0)
        .copied()
        .unwrap_or(LAYERS[0]);
    let dh = h - base;
    let temperature = t0 + lapse * dh;
    let pressure = if lapse == 0.0 {
        p0 * (-G0 * dh / (R * t0)).exp()
    } else {
        p0 * (temperature / t0).powf(-G0 / (lapse * R))
    };
    Air {
        density: pressure / (R * temperature),
        sound: (GAMMA * R * temperature).sqrt(),
        temperature,
        pressure,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_standard_atmosphere_matches_its_table() {
        // US Standard Atmosphere 1976 at geometric heights.
        for (h, rho, a, p) in [
            (0.0, 1.2250, 340.29, 101_325.0),
            (5_000.0, 0.73612, 320.53, 54_019.9),
            (11_000.0, 0.36480, 295.15, 22_699.9),
            (15_000.0, 0.19476, 295.07, 12_111.8),
            (25_000.0, 0.040084, 298.39, 2_549.2),
        ] {
            let air = standard(h);
            assert!((air.density / rho - 1.0).abs() < 1e-3, "{h}: {air:?}");
            assert!((air.sound / a - 1.0).abs() < 1e-3, "{h}: {air:?}");
            assert!((air.pressure / p - 1.0).abs() < 1e-3, "{h}: {air:?}");
        }
    }
}
