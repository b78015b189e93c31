"""The RPLIDAR's wire format both ways: what the simulator encodes, the console's
package (adafruit_rplidar) decodes, and the reverse for the requests."""

from __future__ import annotations

import numpy as np
import pytest
from adafruit_rplidar import RPLidarException, _process_scan

from giraff_console.protocol.rplidar import (
    Command,
    Health,
    ReplyType,
    SendMode,
    decode_samples,
    descriptor,
    encode_samples,
    health_reply,
    info_reply,
    parse_requests,
    request,
    scan_descriptor,
)


def test_a_payload_request_carries_its_size_and_xor_checksum():
    wire = request(Command.SET_MOTOR_PWM, (660).to_bytes(2, "little"))
    assert wire[:3] == bytes((0xA5, 0xF0, 2)) and wire[3:5] == b"\x94\x02"
    checksum = 0
    for byte in wire[:-1]:
        checksum ^= byte
    assert wire[-1] == checksum


def test_requests_are_parsed_back_through_noise_and_split_reads():
    buffer = bytearray(b"\x00\x13" + request(Command.GET_HEALTH) + request(Command.SCAN))
    pwm = request(Command.SET_MOTOR_PWM, b"\x00\x00")
    buffer += pwm[:3]
    found = parse_requests(buffer)
    assert [r.command for r in found] == [Command.GET_HEALTH, Command.SCAN]
    buffer += pwm[3:]
    assert parse_requests(buffer)[0].payload == b"\x00\x00" and not buffer


def test_a_request_with_a_wrong_checksum_is_dropped():
    wire = bytearray(request(Command.SET_MOTOR_PWM, b"\x10\x00"))
    wire[-1] ^= 0xFF
    buffer = wire + request(Command.STOP)
    assert [r.command for r in parse_requests(buffer)] == [Command.STOP]


def test_a_descriptor_packs_length_and_mode_little_endian():
    assert scan_descriptor() == bytes((0xA5, 0x5A, 0x05, 0x00, 0x00, 0x40, 0x81))
    single = descriptor(20, SendMode.SINGLE, ReplyType.INFO)
    assert single[2:6] == (20).to_bytes(4, "little") and single[6] == 0x04
    with pytest.raises(ValueError):
        descriptor(1 << 30, SendMode.SINGLE, ReplyType.INFO)


def test_health_and_info_replies():
    reply = health_reply(Health.WARNING, 0x1234)
    assert reply[:7] == descriptor(3, SendMode.SINGLE, ReplyType.HEALTH)
    assert reply[7:] == bytes((1, 0x34, 0x12))
    info = info_reply(0x18, (1, 29), 7, bytes(16))
    assert len(info) == 7 + 20 and info[7:11] == bytes((0x18, 29, 1, 7))


def test_samples_decode_as_the_package_decodes_them():
    rng = np.random.default_rng(4)
    angles = rng.uniform(0, 360, 200)
    distances = rng.uniform(0, 12000, 200)
    quality = rng.integers(0, 64, 200)
    start = np.zeros(200, dtype=bool)
    start[0] = True
    wire = encode_samples(angles, distances, quality, start)
    ours = decode_samples(wire)
    for i in range(200):
        new_scan, q, angle, distance = _process_scan(wire[5 * i : 5 * i + 5])
        assert new_scan == ours.start[i] == start[i]
        assert q == ours.quality[i] == quality[i]
        assert angle == ours.angle_deg[i] == pytest.approx(angles[i], abs=1 / 128)
        assert distance == ours.distance_mm[i] == pytest.approx(distances[i], abs=0.125)


def test_a_sample_out_of_step_fails_its_checks_both_sides():
    wire = encode_samples(np.array([10.0, 20.0]), np.array([1000.0, 2000.0]),
                          np.array([47, 47]), np.array([True, False]))  # fmt: skip
    # Three bytes on: 1000 mm's low byte (0xA0) leads, its start flags both 0.
    shifted = wire[3:8]
    with pytest.raises(ValueError):
        decode_samples(shifted)
    with pytest.raises(RPLidarException):
        _process_scan(shifted)
