"""The battery gauge: the latest of each charger parameter, and the charge left from W."""

from __future__ import annotations

import pytest

from giraff_console.protocol.charger import ChargerReading, ChargeStatus
from giraff_console.robot.battery import FULL_TO_EMPTY_WS, Battery, BatteryGauge, percent_left

DOCKED = ChargeStatus.FAST_CHARGING
AWAY = ChargeStatus.NOT_DOCKED


def test_nothing_is_known_before_the_first_reading():
    assert BatteryGauge().battery is None


def test_full_half_and_empty_by_the_drivers_formula():
    assert percent_left(0) == 100
    assert percent_left(-FULL_TO_EMPTY_WS / 2) == pytest.approx(50)
    assert percent_left(-FULL_TO_EMPTY_WS) == pytest.approx(0)


def test_the_charge_left_is_clamped():
    # Beyond empty the driver's |(c - W)/c| climbs back up; the gauge says 0.
    assert percent_left(-1.5 * FULL_TO_EMPTY_WS) == 0
    assert percent_left(+1000) == 100


def test_each_parameter_is_kept_until_it_is_read_again():
    gauge = BatteryGauge()
    gauge.update(ChargerReading(AWAY, "B", 25.1))
    gauge.update(ChargerReading(AWAY, "b", -1.2))
    gauge.update(ChargerReading(AWAY, "t", 31.0))
    gauge.update(ChargerReading(AWAY, "D", 0.0))
    gauge.update(ChargerReading(AWAY, "d", 0.0))
    battery = gauge.update(ChargerReading(AWAY, "W", -0.27 * FULL_TO_EMPTY_WS))
    assert battery == Battery(AWAY, pytest.approx(73), 25.1, -1.2, 31.0)
    assert gauge.battery is battery
    battery = gauge.update(ChargerReading(AWAY, "B", 24.9))
    assert battery.voltage == 24.9
    assert battery.percent == pytest.approx(73)


def test_the_percent_is_unknown_until_w_is_read():
    battery = BatteryGauge().update(ChargerReading(AWAY, "B", 25.1))
    assert battery.percent is None
    assert battery.voltage == 25.1
    assert battery.current is None


def test_the_status_is_the_latest_readings():
    gauge = BatteryGauge()
    gauge.update(ChargerReading(AWAY, "B", 25.1))
    assert not gauge.battery.charging
    assert gauge.update(ChargerReading(DOCKED, "b", 2.0)).charging
    assert gauge.update(ChargerReading(ChargeStatus.TRICKLE_CHARGING, "t", 30)).charging
    assert not gauge.update(ChargerReading(ChargeStatus.ERROR, "D", 0.0)).charging
    assert gauge.battery.status is ChargeStatus.ERROR
