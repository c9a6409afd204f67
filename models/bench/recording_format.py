"""The bench-recording format of the ankle actuator (exact: other tools write it).

A recording set is a folder; each experiment is ``NAME.csv`` + ``NAME.json``. Angles follow the paper's sense:
plantarflexion positive, 0 at neutral stance; the linkage deflection is ``alpha = phi - theta``. The joint power
is ``joint_torque_Nm * d(theta)/dt``. A recording holds several consecutive strides.
"""
import numpy as np

from acausal.identify import Column, Key, RecordingFormat
from acausal.identify.plausibility import column_range, first, key_range, sample_interval

#: plausibility ranges of an ankle-actuator bench recording: a value outside is a unit slip (ms, mA, mV, degrees,
#: N mm) or a broken sensor, not physics. The actuator: a 48 V supply, a motor of a few amperes (the paper's
#: EC-4pole 30 peaks near 10 A), a human ankle's torque up to about 2 N m per kg of body mass, MACCEPA levers of
#: centimetres (the paper's A = 0.1 m, B = 0.06 m), a transmission ratio in the hundreds (the paper's 860)
RANGES = {"sample interval": (1e-5, 0.1), "angle": (-2 * np.pi, 2 * np.pi), "joint_torque_Nm": (-1000.0, 1000.0),
          "supply_voltage_V": (0.0, 200.0), "supply_current_A": (-200.0, 200.0), "motor_current_A": (-200.0, 200.0),
          "precompression_m": (0.0, 0.1), "stride_time_s": (0.2, 20.0), "spring_stiffness_N_per_m": (1e3, 1e7),
          "body_mass_kg": (1.0, 500.0), "lever_A_m": (0.001, 1.0), "lever_B_m": (0.001, 1.0),
          "gear_ratio": (1.0, 1e4)}
#: the largest angular acceleration of the ankle and the moment arm [rad/s^2]: a walking ankle's peaks are a few
#: hundred rad/s^2 at push-off, the moment arm follows through the gear; ten times past that, a sample off the line
#: through its neighbours by more is an encoder read error, never motion
MAX_ACCEL = 2000.0
_UNITS = {"joint_torque_Nm": "N m", "supply_voltage_V": "V", "supply_current_A": "A", "motor_current_A": "A"}


def _plausible(columns: dict, meta: dict) -> str | None:
    """What makes a bench recording physically implausible (see :data:`RANGES`), or None."""
    angles = ("ankle_angle_rad", "moment_arm_angle_rad", "moment_arm_setpoint_rad")
    keys = ("precompression_m", "stride_time_s", "spring_stiffness_N_per_m", "body_mass_kg", "supply_voltage_V",
            "lever_A_m", "lever_B_m", "gear_ratio")
    return first(
        sample_interval(columns["time_s"], RANGES["sample interval"], "a bench is sampled"),
        *(column_range(columns, n, RANGES["angle"], "rad", "degrees in a column of radians?") for n in angles),
        *(column_range(columns, n, RANGES[n], u, "another unit, or a broken sensor? (the ankle actuator's bench)")
          for n, u in _UNITS.items()),
        *(key_range(meta, k, RANGES[k], "mm for m, g for kg, N/mm for N/m, mV for V?") for k in keys))


def recorded_span(meta: dict):
    """The time a recording must cover by its JSON: ``strides`` x ``stride_time_s`` (None without ``strides``)."""
    return meta["strides"] * meta["stride_time_s"] if "strides" in meta else None


ANKLE_FORMAT = RecordingFormat(
    name="ankle actuator bench recording",
    columns=(
        Column("time_s", "s", "sample time, strictly increasing"),
        Column("ankle_angle_rad", "rad", "ankle angle theta (plantarflexion positive, 0 at neutral stance)",
               bounds=RANGES["angle"], max_accel=MAX_ACCEL),
        Column("moment_arm_angle_rad", "rad", "moment-arm angle phi relative to the lower leg, same sense",
               bounds=RANGES["angle"], max_accel=MAX_ACCEL),
        Column("moment_arm_setpoint_rad", "rad", "moment-arm angle reference phi_ref of the controller"),
        Column("joint_torque_Nm", "Nm", "torque the actuator applies to the foot, plantarflexion positive",
               bounds=RANGES["joint_torque_Nm"]),
        Column("supply_voltage_V", "V", "supply voltage", bounds=RANGES["supply_voltage_V"]),
        Column("supply_current_A", "A", "supply current into the driver", bounds=RANGES["supply_current_A"]),
        Column("motor_current_A", "A", "torque-producing motor current as the driver reports it",
               bounds=RANGES["motor_current_A"]),
    ),
    keys=(
        Key("precompression_m", "m", "nominal spring precompression P"),
        Key("stride_time_s", "s", "duration of one stride"),
        Key("spring_stiffness_N_per_m", "N/m", "spring stiffness k"),
        Key("body_mass_kg", "kg", "body mass the gait torque was scaled with"),
        Key("supply_voltage_V", "V", "nominal supply voltage (overrides the model's 48 V)", required=False),
        Key("lever_A_m", "m", "MACCEPA connecting-link length A (overrides 0.1 m)", required=False),
        Key("lever_B_m", "m", "MACCEPA moment-arm length B (overrides 0.06 m)", required=False),
        Key("gear_ratio", "1", "total transmission ratio (overrides 860)", required=False),
        Key("strides", "", "number of consecutive strides recorded", required=False, kind="integer"),
        Key("session_time_s", "s", "when the recording started, seconds since the session's first recording "
            "started: orders a session's recordings for the drift check", required=False, positive=False),
        Key("description", "", "free text", required=False, kind="text"),
    ),
    expected_span=recorded_span,
    checks=(_plausible,),
    # a lost read of the bench's data logger: the electrical and torque channels all exactly 0 (noise never is)
    dropout=("joint_torque_Nm", "supply_voltage_V", "supply_current_A", "motor_current_A"),
)


#: model variable behind each recorded column (the simulated reading of that sensor), in
#: :meth:`AnkleActuator.eq4 <acausal.models.ankle.actuator.AnkleActuator.eq4>`
SIGNALS = {"motor_current_A": "motor.i", "supply_current_A": "P_source.i", "joint_torque_Nm": "joint_torque",
           "supply_voltage_V": "P_source.v"}


def model_params(meta: dict) -> dict:
    """The recording's settings as parameter overrides of the Eq. (4) model
    (:meth:`AnkleActuator.eq4 <acausal.models.ankle.actuator.AnkleActuator.eq4>`)."""
    p = {"P_nominal": meta["precompression_m"], "stride_time": meta["stride_time_s"],
         "link.k": meta["spring_stiffness_N_per_m"]}
    optional = {"supply_voltage_V": "supply.V", "lever_A_m": "link.A", "lever_B_m": "link.B",
                "gear_ratio": "gear.ratio"}
    p.update({name: meta[key] for key, name in optional.items() if key in meta})
    return p
