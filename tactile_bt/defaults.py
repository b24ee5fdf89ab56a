"""One place for the constants and defaults of the framework.

Every number that describes the hardware of the paper (Li et al., RSS 2013, Sec. III and V)
or a default of the control loop lives here, in SI units.  Modules import from here instead of
repeating literals; scenes, trees and ``--set`` overrides change them per run.
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
