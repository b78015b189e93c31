"""A revolution's samples as beams in the robot's frame (lidar/scan.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from giraff_console.lidar.scan import LidarScan, Mount, robot_beams, whole_turn, within


def beams(angles, distances, quality=None, mount=None):
    q = np.full(len(angles), 47) if quality is None else np.asarray(quality)
    mount = mount or Mount()
    return robot_beams(np.asarray(angles, float), np.asarray(distances, float), q, mount,
                       0.15, 12.0)  # fmt: skip


def test_the_sensors_clockwise_angles_become_counter_clockwise_bearings():
    # 90 degrees clockwise on the sensor is the robot's right: bearing -pi/2.
    (right, ahead) = beams([90.0, 0.0], [1000.0, 2000.0])
    assert right == pytest.approx((1.0, -math.pi / 2))
    assert ahead == pytest.approx((2.0, 0.0))


def test_no_return_and_out_of_range_are_misses():
    found = beams([0.0, 10.0, 20.0, 30.0], [0.0, 1000.0, 100.0, 13000.0], [47, 0, 47, 47])
    assert all(math.isinf(distance) for distance, _ in found)


def test_the_mount_moves_beams_to_the_robots_centre():
    # The sensor 0.2 m ahead and turned 90 degrees left: its front sees 1 m to the left
    # of itself, which from the centre is atan2(1, 0.2) away.
    (beam,) = beams([0.0], [1000.0], mount=Mount(0.2, math.pi / 2))
    assert beam == pytest.approx((math.hypot(0.2, 1.0), math.atan2(1.0, 0.2)))


def test_within_a_range_farther_hits_are_misses():
    scan = LidarScan(12.0, ((1.0, 0.0), (3.0, 0.5)), 0.0, 2)
    near = within(scan, 1.5)
    assert near.range_max == 1.5 and near.beams[0] == (1.0, 0.0)
    assert math.isinf(near.beams[1][0])


def test_lidar_settings_errors_name_the_line(tmp_path):
    from giraff_console.settings import SettingsError, load_settings

    path = tmp_path / "config.toml"
    path.write_text('port = "/dev/ttyS0"\n\n[lidar]\nport = "/dev/ttyUSB0"\nyaw = 500\n')
    with pytest.raises(SettingsError, match=r"config.toml:5: lidar.yaw must be"):
        load_settings(path)
    path.write_text('[lidar]\nport = "/dev/ttyUSB0"\nbaudrate = 9600\n')
    with pytest.raises(SettingsError, match=r"config.toml:3: lidar.baudrate must be one of"):
        load_settings(path)
    path.write_text('[lidar]\nport = "/dev/ttyUSB0"\nforward = 0.1\n')
    lidar = load_settings(path).lidar
    assert lidar.port == "/dev/ttyUSB0" and lidar.forward == 0.1 and lidar.baudrate == 115200


def test_lidar_without_a_port_on_a_real_robot_is_a_usage_error(capsys):
    from giraff_console.cli.main import main

    code = main(["go", "kitchen", "--port", "/dev/null", "--lidar"])
    assert code == 2 and "--lidar: give its port" in capsys.readouterr().err


def test_a_whole_turn_is_one_sweep_with_no_sample_lost():
    def whole(angles, measured=None):
        angles = np.asarray(angles, float)
        return whole_turn(angles, np.ones(len(angles), bool) if measured is None else measured)

    a1 = np.arange(360) * 1.0 + 0.3  # an A1's samples, from just past its start flag
    assert whole(a1)
    assert whole(np.arange(16) * 22.5)  # a sparse sensor's, evenly spaced
    # The angles' jitter, unsorted, and a first sample just short of the turn's end.
    assert whole(a1 + np.random.default_rng(1).uniform(-0.4, 0.4, 360))
    assert whole(np.mod(a1 - 0.5, 360.0))
    # A real sensor's turn holds no whole number of samples (an A1 330 to 400, an A3
    # about 1450), read to 1/64 degree and cut at the start flag: every turn whole.
    for per_turn in (330.8, 363.6, 395.7, 1450.6):
        swept = np.arange(int(per_turn * 20)) * (360.0 / per_turn) + 0.17
        turn = np.floor(swept / 360.0)
        for k in range(1, 19):
            angles = np.round(np.mod(swept[turn == k], 360.0) * 64) / 64
            assert whole(angles), (per_turn, k)
    # A sample that measured nothing carries no angle to go by (the sensor's own SDK
    # rewrites it): one out of place is passed over.
    odd = a1.copy()
    odd[100] = 262.0
    measured = np.ones(360, bool)
    assert not whole(odd)
    measured[100] = False
    assert whole(odd, measured)
    # Samples lost: a run of them in the middle, the turn's end, or the start flag
    # between two turns (the next turn's angles run on from 0 in the same revolution).
    assert not whole(np.delete(a1, range(100, 104)))
    assert not whole(a1[:300])
    assert not whole(np.concatenate([a1, a1]))
    assert not whole(a1[:1])
