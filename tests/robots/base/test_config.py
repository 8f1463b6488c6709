"""Base configurations (the shipped base_*.yaml) and every malformed one refused with its line.

Facts: seed 000 Appendix A (EX-106+, Protocol 1.0, 1 Mbps from dxl_initialize(16, 1), wheel
radius 5.2 cm and wheel base 38 cm in Figure A3, IDs 0 and 1; A.2's four motors 1-4, 1 and 2
clockwise and 3 and 4 counter-clockwise forwards, on 0.1021 m wheels by final.m's 5265/575
counts a mm); ROBOTIS OpenCR turtlebot3_waffle.h
(WHEEL_RADIUS 0.033 m, WHEEL_SEPARATION 0.287 m) and turtlebot3_teleop (0.26 m/s, 1.82 rad/s)."""

from __future__ import annotations

from pathlib import Path

import pytest

from servolab.robots.base.config import SHIPPED_DIR, BaseConfigError, load

CONFIGS = SHIPPED_DIR  # the shipped bases: package data of servolab.robots.base


def test_the_three_bases() -> None:
    seed = load(CONFIGS / "base_seed000.yaml")
    assert (seed.model.name, seed.protocol, seed.baudrate, seed.wheel_radius,
            seed.wheel_separation) == ("EX-106+", 1, 1_000_000, 0.052, 0.38)
    assert [(m.id, m.side) for m in seed.motors] == [(0, "left"), (1, "right")]
    four = load(CONFIGS / "base_seed000_4motor.yaml")
    assert [m.id for m in four.side("left")] == [1, 2] and [m.id for m in four.side("right")] \
        == [3, 4]
    assert {m.direction for m in four.side("left")} == {-1}  # clockwise forwards (A.2)
    # A.2's wheel, from final.m's 5265/575 counts a mm (test_a2.py), not Figure A3's 5.2 cm
    assert (four.wheel_radius, four.wheel_separation) == (0.1021, 0.38)
    waffle = load(CONFIGS / "base_turtlebot3_waffle.yaml")
    assert (waffle.model.name, waffle.protocol, waffle.wheel_radius, waffle.wheel_separation,
            waffle.max_linear_velocity, waffle.max_angular_velocity) == (
        "XM430-W210", 2, 0.033, 0.287, 0.26, 1.82)


GOOD = (CONFIGS / "base_seed000.yaml").read_text()


@pytest.mark.parametrize(("old", "new", "says"), [
    ("  wheel_radius: 0.052\n", "", "key 'wheel_radius' missing"),
    ("wheel_radius: 0.052", "wheel_radius: -0.052", "wheel_radius must be a distance"),
    ("wheel_radius: 0.052", "wheel_radius: .nan", "must be a finite number"),
    ("wheel_separation: 0.38", "wheel_separation: 0", "wheel_separation must be"),
    ("model: EX-106+", "model: EX-107", "base.model"),
    ("protocol: 1", "protocol: 2", "speaks Protocol 1.0"),
    ("baudrate: 1000000", "baudrate: 1234", "base.baudrate"),
    ("{id: 1, side: right, direction: -1}", "{id: 1, side: right, direction: 0}",
     "direction must be 1 or -1"),
    ("{id: 1, side: right, direction: -1}", "{id: 1, side: left, direction: -1}",
     "no right wheel motor"),
    ("{id: 1, side: right, direction: -1}", "{id: 0, side: right, direction: -1}",
     "id 0 is given twice"),
    ("wheel_radius: 0.052", "wheel_radius: 0.052\n  max_linear_velocity: 5.0",
     "is over what a EX-106\\+ can drive"),
    ("wheel_radius: 0.052", "wheel_radus: 0.052", "did you mean 'wheel_radius'"),
    ("wheel_radius: 0.052", "wheel_radius: 0.052\n  wheel_clamp: per_wheel",
     "wheel_clamp must be scaled or per-wheel, not 'per_wheel' \\(did you mean 'per-wheel'"),
])
def test_a_bad_base_is_refused_naming_the_key(tmp_path: Path, old: str, new: str,
                                              says: str) -> None:
    path = tmp_path / "base.yaml"
    assert old in GOOD
    path.write_text(GOOD.replace(old, new))
    with pytest.raises(BaseConfigError, match=says) as info:
        load(path)
    assert str(info.value).startswith(f"{path}:") and "\n" not in str(info.value)
