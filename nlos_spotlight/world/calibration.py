"""Photometric calibration of the synthetic world to the paper's hardware class.

Units: the renderer carries radiance per RGB channel (W sr^-1 m^-2), each channel standing for the
radiant power of its third of the visible band; the sensor model (``render/sensor.py``) converts
channel radiance to photo-electrons at 550 nm.

Projector (a 4000-lumen business projector showing one white spot on black):

* Throw ratio 1.5 and a 16:9 panel give a 36.9 x 21.3 degree image, a solid angle of
  ``4 asin(sin(a/2) sin(b/2)) = 0.233 sr``.
* Full white spreads 4000 lm over it: luminous intensity 4000 / 0.233 = 17,150 cd. A spot
  is a white disk on a black image, so inside the spot the intensity is the same (a projector
  blocks, it does not concentrate), and the spot's half-angle is set by the disk's size.
* White projector light has a luminous efficacy of about 300 lm per radiant watt (lamp and LED
  projector spectra: 250-350 lm/W), so I = 17,150 / 300 = 57 W/sr in total, 19 W/sr per channel.

Ambient light (indoor, room lights dimmed for the measurement, as in the paper's captures):

* Illuminance on the visible walls 2-40 lux (light spilling in from a corridor, a window at dusk,
  a dimmed lamp). A uniform light field of radiance L gives irradiance E = pi L, so
  L = E / pi / 300 lm/W / 3 channels: 2 lux -> 0.0007, 40 lux -> 0.014 W sr^-1 m^-2 per channel.
* The hidden region, around the corner, gets less of it: 0.1-2 lux (a dark hallway at night is
  about 1 lux). Why it matters: a person lit at 150 lux (an office with the lights on) sends ~30x
  more light to the relay wall than the spot does after its extra bounce (spot flux ~0.05 W per
  channel at 3 degrees, ~7% of it reaching the body from the wall, versus 0.17 W/m^2 on ~1 m^2 of
  body), and the camera, exposed for the bright spot, would then gain nothing from the
  projector: the method of the paper is for dim scenes, and the world is calibrated for them.

The sensor (APS-C, f/2, binned to the output resolution, 14-bit) is derived in ``render/sensor.py``.
"""

from __future__ import annotations

import math

LUMENS = 4000.0
"""Projector luminous flux for full white."""
THROW_RATIO = 1.5
"""Projector throw ratio (distance / image width)."""
ASPECT = 16 / 9
"""Projector panel aspect ratio."""
LM_PER_W = 300.0
"""Luminous efficacy of white projector or room light, lm per radiant W."""


def projector_solid_angle(throw_ratio: float = THROW_RATIO, aspect: float = ASPECT) -> float:
    """Solid angle (sr) of a rectangular projection: 4 asin(sin(a/2) sin(b/2))."""
    a = 2 * math.atan(1 / (2 * throw_ratio))
    b = 2 * math.atan(1 / (2 * throw_ratio * aspect))
    return 4 * math.asin(math.sin(a / 2) * math.sin(b / 2))


def projector_intensity_per_channel(lumens: float = LUMENS) -> float:
    """Radiant intensity (W/sr) per RGB channel inside a white spot."""
    return lumens / projector_solid_angle() / LM_PER_W / 3


def ambient_radiance_per_channel(lux: float) -> float:
    """Radiance (W sr^-1 m^-2 per channel) of a uniform light field giving ``lux`` on a surface."""
    return lux / math.pi / LM_PER_W / 3


def illuminance_lux(radiance_per_channel) -> float:
    """Illuminance (lux) a uniform light field of this radiance per channel gives a surface (the
    inverse of :func:`ambient_radiance_per_channel`; a tinted field counts its channels' mean)."""
    return float(sum(radiance_per_channel) / len(radiance_per_channel)) * math.pi * LM_PER_W * 3


PROJECTOR_INTENSITY = projector_intensity_per_channel()
"""~19 W/sr per channel."""
AMBIENT_LUX = (2.0, 40.0)
"""Range of LOS wall illuminance from dimmed room light, lux."""
HIDDEN_LUX = (0.1, 2.0)
"""Range of the hidden region's illuminance, lux."""
