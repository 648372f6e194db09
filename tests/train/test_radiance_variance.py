"""``train.imaging.radiance_variance`` is the variance of the noise ``add_sensor_noise`` draws."""

from __future__ import annotations

import torch

from nlos_spotlight.render.sensor import SensorConfig
from nlos_spotlight.render.sensor import auto_exposure
from nlos_spotlight.train.imaging import add_sensor_noise, radiance_variance


def test_radiance_variance_matches_the_drawn_noise():
    sensor = SensorConfig.at((4, 4))
    reference = torch.full((4, 4, 3), 2.0)
    frame = torch.linspace(0.2, 3.0, 48).reshape(4, 4, 3)  # below full scale: nothing clips
    exposure = auto_exposure(reference, sensor)
    gen = torch.Generator().manual_seed(0)
    draws = torch.stack([add_sensor_noise(frame[None], exposure, sensor, gen)[0][0] for _ in range(4000)])
    empirical = draws.var(0)
    # the variance of a sample variance of 4000 Gaussian draws is 2 var^2 / 3999: within 4.5 sigma
    torch.testing.assert_close(empirical, radiance_variance(frame, reference, sensor), rtol=0.1, atol=0.0)
