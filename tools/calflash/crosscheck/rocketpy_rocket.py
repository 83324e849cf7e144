#!/usr/bin/env python3
"""RocketPy's flight of calflash's default rocket (sim/flight/rocket.rs), the peer simulator
the rocket is checked against (BENCHMARKS.md, "The simulator against theory"): the same thrust
curve, mass (30 kg wet, 24 kg dry, propellant burnt in proportion to the impulse), diameter,
inertia, drag curve, rail and elevation; the standard atmosphere, no wind, constant gravity.
The nose and fins are there for RocketPy's stability only (it takes the drag from the curve).

    python3 -m venv /tmp/rpy && /tmp/rpy/bin/pip install rocketpy
    /tmp/rpy/bin/python tools/calflash/crosscheck/rocketpy_rocket.py
    calflash simulate --sensor imu --flight rocket -o r.csv --flight-truth rt.csv
"""
from rocketpy import Environment, GenericMotor, Rocket, Flight
env = Environment(latitude=0, longitude=0, elevation=0, gravity=9.80665)
env.set_atmospheric_model(type="standard_atmosphere")
motor = GenericMotor(
    thrust_source=[(0, 0), (0.05, 1800), (5.9, 1800), (6.0, 0)],
    burn_time=6.0, chamber_radius=0.07, chamber_height=1.0, chamber_position=0.5,
    propellant_initial_mass=6.0, dry_mass=0.0, dry_inertia=(0, 0, 0), nozzle_radius=0.05,
    center_of_dry_mass_position=0.5, nozzle_position=0,
    coordinate_system_orientation="nozzle_to_combustion_chamber")
drag = [(0.0, 0.45), (0.8, 0.47), (0.9, 0.52), (1.0, 0.65), (1.2, 0.60), (2.0, 0.45)]
rocket = Rocket(radius=0.078, mass=24.0, inertia=(22.5, 22.5, 0.09),
                power_off_drag=drag, power_on_drag=drag,
                center_of_mass_without_motor=0, coordinate_system_orientation="tail_to_nose")
rocket.add_motor(motor, position=-1.5)
rocket.add_nose(length=0.5, kind="vonKarman", position=1.5)
rocket.add_trapezoidal_fins(n=4, root_chord=0.3, tip_chord=0.15, span=0.15, position=-1.1)
f = Flight(rocket=rocket, environment=env, rail_length=12, inclination=84, heading=0,
           terminate_on_apogee=True, max_time_step=0.01)
print(f"rail exit {f.out_of_rail_time:.3f} s at {f.out_of_rail_velocity:.2f} m/s")
print(f"apogee {f.apogee - env.elevation:.1f} m at {f.apogee_time:.2f} s")
print(f"max speed {f.max_speed:.1f} m/s at {f.max_speed_time:.2f} s")
print(f"burnout speed {f.speed(6.0):.1f} m/s, height {f.z(6.0):.1f} m")
