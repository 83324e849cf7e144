//! The options every command that reads a mission profile takes (`mission`, `calibrate
//! --mission`, `design --mission`).

use clap::Args;

/// The options every command that reads a mission profile takes.
#[derive(Debug, Args, Clone)]
pub struct MissionColumns {
    /// Columns of the mission profile chosen by name, with their units where the names do not
    /// state them: `t=ts,fx=Ay:m/s^2,wx=Gy:deg/s,...` (roles t, fx, fy, fz, wx, wy, wz, dwx,
    /// dwy, dwz, temp, volt). Roles not given are found by the header's names (t, ts, time_ms;
    /// f_x, ax, acc_x; w_x, gx, gyro_x; dw_x; temp; volt), in SI unless a name states its unit.
    #[arg(long, default_value = "")]
    pub mission_columns: String,
}
