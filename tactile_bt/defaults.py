"""One place for the constants and defaults of the framework.

Every number that describes the hardware of the paper (Li et al., RSS 2013, Sec. III and V)
or a default of the control loop lives here, in SI units.  Modules import from here instead of
repeating literals; scenes, trees and ``--set`` overrides change them per run.

Layer: base.
"""

from __future__ import annotations

#: Number of tactel rows and columns of the pad (paper Sec. III).
ROWS: int = 16
COLS: int = 16
#: Tactel pitch in metres (5 mm, paper Sec. III).
PITCH_M: float = 0.005
#: Area of one tactel in square metres.
TACTEL_AREA_M2: float = PITCH_M * PITCH_M
#: ADC resolution: raw tactel values are integers in ``[0, ADC_MAX]`` (12 bit).
ADC_BITS: int = 12
ADC_MAX: int = (1 << ADC_BITS) - 1

#: Sensing and control rate in Hz (paper Sec. V).
RATE_HZ: float = 250.0
#: Highest frame rate of the sensor in Hz (paper Sec. III).
MAX_SENSOR_RATE_HZ: float = 1900.0

#: Target contact pressure in Pa: the paper's p = 1 is about 2 kPa (2 N over 40 tactels).
TARGET_PRESSURE_PA: float = 2000.0
#: Binarisation threshold of the force image in newtons per tactel, just above the noise.
CONTACT_THRESHOLD_N: float = 0.008
#: Samples in the moving average of pressure and orientation (10 samples = 40 ms at 250 Hz).
SMOOTHING_SAMPLES: int = 10

# --- Servo leaves (gains per feature component; tuned on the simulator) -----------------------
#: Force (pressure) hold: vz [m/s] per Pa of pressure error, integral per Pa·s, derivative per Pa/s.
FORCE_KP: float = 1.0e-4
FORCE_KI: float = 1.0e-4
FORCE_KD: float = 0.0
FORCE_LIMIT_MPS: float = 0.05
#: Contact position (COP) by sliding: vx, vy [m/s] per m of COP error. Sliding integrates the
#: command into the COP, so proportional action alone settles without offset; an integral term
#: would only add a slow overshoot tail (and, under a guidance twist, cancel it).
CENTRE_KP: float = 4.0
CENTRE_KI: float = 0.0
CENTRE_KD: float = 0.0
CENTRE_LIMIT_MPS: float = 0.03
#: Convergence band of a COP error component (m): 0.5 mm, a tenth of the paper's tactel. In
#: metres, so it does not change with the scene's pitch (``band: 0.1 px`` gives a tenth of its).
COP_BAND_M: float = 0.5e-3
#: COP by rolling: the position command of the rolling rows (m/s per m), turned into rad/s by
#: dividing by ROLL_RADIUS_M (the inverse task Jacobian's rolling rows).
ROLL_KP: float = 1.0
ROLL_KI: float = 0.0
ROLL_KD: float = 0.0
ROLL_LIMIT_MPS: float = 0.02
ROLL_RADIUS_M: float = 0.05
#: Edge alignment: wz [rad/s] per rad of orientation error.
ALIGN_KP: float = 8.0
ALIGN_KI: float = 8.0
ALIGN_KD: float = 0.0
ALIGN_LIMIT_RPS: float = 1.0

# --- Forces the object can carry (tactile_bt.tree.behaviours.stiffness) -----------------------
#: Lowest pressure target a soft object may bring the tree's target down to (Pa): below it the
#: contact region falls apart into tactels just above the binarisation threshold (0.008 N on a
#: 25 mm² tactel: 320 Pa), and the pressure, force over the region's area, cannot go below that.
FORCE_TARGET_FLOOR_PA: float = 0.25 * TARGET_PRESSURE_PA
#: Share of what an object can give before the pad reaches something hard that the pressure
#: target may use.
STIFFNESS_GIVE_SHARE: float = 0.5
#: What an object is taken to give when the set-up's table below is farther (m).
STIFFNESS_MAX_INDENTATION_M: float = 0.005
#: Indentation of a contact before its stiffness estimate counts (m).
STIFFNESS_MIN_TRAVEL_M: float = 0.0002
#: Rise of the pressure of a contact before its stiffness estimate counts (Pa): several times the
#: noise of the unsmoothed pressure of a small contact.
STIFFNESS_MIN_RISE_PA: float = 0.05 * TARGET_PRESSURE_PA

# --- Chatter of the servo leaves (tactile_bt.control.chatter.ChatterDamper) ---------------------
#: A sign change of a servo output between two cycles counts as chatter when it jumps by at
#: least this share of the output limit ...
SERVO_CHATTER_JUMP_SHARE: float = 0.5
#: ... and comes within this time of the previous one (s) ...
SERVO_CHATTER_GAP_S: float = 0.05
#: ... and raises the chatter level (0-1) by this much, ...
SERVO_CHATTER_STEP: float = 0.25
#: ... which falls back from 1 to 0 in this time without chatter (s).
SERVO_CHATTER_RECOVER_S: float = 1.0
#: Gain of a servo output at full chatter (its share of the PID's output).
SERVO_CHATTER_GAIN_MIN: float = 0.3
#: Time constant of the low-pass on a servo output at full chatter (s).
SERVO_CHATTER_SMOOTH_S: float = 0.1
#: A pad rocks between two contacts (tactile_bt.control.chatter.RockingDetector) when the largest
#: region's centre of pressure jumps by more than this share of the pad's width, another region
#: under the pad, ...
ROCKING_JUMP_SHARE: float = 0.5
#: ... this many times ...
ROCKING_CHANGES: int = 2
#: ... within this time (s).
ROCKING_WINDOW_S: float = 0.5
#: roll_to holds the tilt of a rocking pad that the supervisor has pulled back within this time (s).
ROCKING_PULLED_BACK_S: float = 1.0

# --- Contacts recorded only when settled (tactile_bt.tree.behaviours.contact_points) ----------
#: record_contacts records while the smoothed pressure is at most this many times the target ...
RECORD_MAX_PRESSURE_RATIO: float = 2.0
#: ... and at least this many times it ...
RECORD_MIN_PRESSURE_RATIO: float = 0.25
#: ... while contact outside the largest region carries at most this share of its force ...
RECORD_OTHER_REGION_SHARE: float = 0.2
#: ... and while the pad moves into the object along its normal at most this fast (m/s): the
#: approach's speed. The force servo's own corrections on a curved surface reach a few mm/s.
RECORD_MAX_APPROACH_MPS: float = 0.01
#: The spread (tactels, standard deviation across the force image) of a line contact, such as an
#: edge under a tilted pad, on the simulated pad: the foam's spread and the tactels' width, as the
#: contact region's threshold leaves it; ``record_contacts {region_spread_px: 0.75}`` draws an
#: imprint no wider in to its line
#: (:func:`tactile_bt.tree.behaviours.contact_points.imprint_points`).
IMPRINT_SPREAD_PX: float = 0.75

#: Approach: speed along the pad normal (m/s) and the pressure that ends it (Pa).
APPROACH_SPEED_MPS: float = 0.01
APPROACH_PRESSURE_PA: float = 0.4 * TARGET_PRESSURE_PA
#: Guided slide: default external twist V_ext along the sensor y axis (m/s).
SLIDE_SPEED_MPS: float = 0.02
#: Limits on the summed twist of one cycle.
TWIST_LINEAR_LIMIT_MPS: float = 0.05
TWIST_ANGULAR_LIMIT_RPS: float = 1.5

# --- The compliant arm (KUKA LWR 4 in joint impedance mode) -----------------------------------
#: Joint stiffness of the compliance mode (N m/rad, paper Sec. V).
ARM_STIFFNESS_NM_PER_RAD: float = 200.0
#: Joint damping of the compliance mode (N m s/rad, paper Sec. V).
ARM_DAMPING_NMS_PER_RAD: float = 0.2

#: A point of a scanned surface counts as covered within this distance (m) of a contact: in the
#: scan figures (tactile_bt.mission.accuracy) and in the frontier planner's estimate of the band
#: the table leaves (tactile_bt.contacts.untouched.untouched_below).
COVERAGE_RADIUS_M: float = 0.002

# --- Metrics (the columns of the paper's Tables I-III) -----------------------------------------
#: Convergence bands for the response time, per logged error (Pa, px, px, rad).
METRIC_BANDS = {
    "pressure_pa": 0.1 * TARGET_PRESSURE_PA,
    "cop_x_px": 0.25,
    "cop_y_px": 0.25,
    "orientation_rad": 0.0524,  # 3 degrees
}
#: Time the error must stay inside its band to count as settled (s).
METRIC_DWELL_S: float = 0.5
#: Length of the evaluation window after a controller starts (s): the paper's "until 20 s".
METRIC_WINDOW_S: float = 20.0
#: Force figures of a mission (:func:`tactile_bt.mission.metrics.force_figures`): the smoothed
#: pressure may exceed this multiple of the held target ...
FORCE_FIGURE_PRESSURE_FACTOR: float = 2.0
#: ... for at most this long at a time (s).
FORCE_FIGURE_MAX_OVER_S: float = 0.1
#: A twist row chatters when it changes sign between consecutive cycles with a jump of at least
#: this share of its limit (``TWIST_LINEAR_LIMIT_MPS`` or ``TWIST_ANGULAR_LIMIT_RPS``).
CHATTER_FIGURE_JUMP_SHARE: float = 0.2

# --- Supervisor (between the controller and the mount; no tree switches it off) --------------
#: Default pressure limit as a multiple of the highest pressure target of the tree's leaves.
SUPERVISOR_PRESSURE_FACTOR: float = 2.0
#: Highest pressure limit a scene or run may declare (Pa): 10x the paper's target.
SUPERVISOR_PRESSURE_CAP_PA: float = 10.0 * TARGET_PRESSURE_PA
#: Absolute cap on the contact force (N): the default force limit, and the highest one allowed.
SUPERVISOR_FORCE_CAP_N: float = 20.0
#: Time a limit may be exceeded, in all, within one intervention (the supervisor retreating all
#: that time) before the mission fails (s).
SUPERVISOR_GRACE_S: float = 0.5
#: Time within every limit after which an intervention counts as over (s).
SUPERVISOR_CLEAR_S: float = 0.2
#: Longest grace and clear time a scene or run may declare (s).
SUPERVISOR_MAX_WAIT_S: float = 2.0
#: A second contact region seen this recently (s) still keeps the retreat from sliding towards
#: it: a flat pad rocking between the rims of a groove bears them one at a time, and sliding away
#: from the one under its border presses the other.
SUPERVISOR_BRIDGE_MEMORY_S: float = 0.2
#: Speed of the retreat along the pad normal, away from the object (m/s): as fast as the force
#: hold backs off. On the compliant arm the pad gives back only as its joints unwind, so a
#: slower retreat leaves a small contact (a corner) above the limit for longer.
SUPERVISOR_RETREAT_SPEED_MPS: float = FORCE_LIMIT_MPS
#: Live missions: the longest gap between sensor frames (s; 10 frames at 250 Hz) ...
SUPERVISOR_SENSOR_SILENCE_S: float = 0.04
#: ... and the oldest robot pose (s) the supervisor accepts before it stops the mission.
SUPERVISOR_POSE_STALE_S: float = 0.04
#: Longest silence and pose age a scene or run may declare (s).
SUPERVISOR_MAX_STALE_S: float = 1.0

# --- Watching a mission ------------------------------------------------------------------------
#: Rate (Hz of mission time) at which ``--rerun`` logs the force image, the features and the
#: pad's pose; node status changes are logged at every tick.
RERUN_RATE_HZ: float = 50.0

# --- Live missions ------------------------------------------------------------------------------
#: A live mission's sensor falls silent after this many control periods without a new frame
#: (the supervisor's ``sensor_silence_s`` where the robot file sets none).
LIVE_SENSOR_SILENCE_PERIODS: int = 4

#: Cell size (m) of the signed-distance grid through which the pad model evaluates a shape that
#: has no compiled form of its own (:mod:`tactile_bt.sim.sdf_grid`): the meshes' default.
SHAPE_GRID_RESOLUTION_M: float = 1.0e-3
#: Largest such grid (points, 8 bytes each); a larger shape gets coarser cells.
SHAPE_GRID_MAX_POINTS: int = 4_000_000
