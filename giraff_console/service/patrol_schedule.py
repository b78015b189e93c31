"""The settings' scheduled patrols, run by the daemon (issue 15, item 5).

One owned thread looks at the clock every few seconds and asks the schedule
(missions/schedule.py) which slots have come. A slot whose patrol is still running from
its last start is skipped, as is one that comes while the robot is busy with something
else (another mission, or the operator driving it by the keys): a night patrol must not
take the robot from under a caregiver's hands. Every skip is written to the patrol log
beside the runs, so that `giraff-console patrols` shows it with its reason.
"""

from __future__ import annotations

import datetime as dt
import logging
import threading
from collections.abc import Callable
from pathlib import Path

from giraff_console.missions.patrol_log import PatrolRunLog
from giraff_console.missions.schedule import Decision, ScheduledPatrol, Scheduler
from giraff_console.service.robot_service import RobotService

log = logging.getLogger(__name__)

# Seconds between looks at the clock: a slot starts at most this late.
LOOK_EVERY_S = 10.0


class PatrolSchedule:
    """Runs `entries` on `service`, logging skips in `runs`; `now` is the local time."""

    def __init__(self, service: RobotService, entries: tuple[ScheduledPatrol, ...],
                 runs: Path | None,
                 now: Callable[[], dt.datetime] = dt.datetime.now) -> None:  # fmt: skip
        self.service = service
        self.runs = runs
        self.now = now
        self.scheduler = Scheduler(entries, now())
        self._exit = threading.Event()
        self._thread: threading.Thread | None = None

    def start(self) -> None:
        if not self.scheduler.entries:
            return
        for entry, due in self.scheduler.upcoming():
            self.service.note(f"scheduled: patrol {entry.patrol} next at {due:%a %H:%M}")
        self._thread = threading.Thread(target=self._run, name="patrol-schedule", daemon=True)
        self._thread.start()

    def stop(self, timeout: float = 2.0) -> None:
        self._exit.set()
        if self._thread is not None:
            self._thread.join(timeout)

    def _run(self) -> None:
        while not self._exit.wait(LOOK_EVERY_S):
            self.look()

    def look(self) -> None:
        """Start or skip the slots that have come since the last look."""
        for decision in self.scheduler.tick(self.now(), self._running):
            try:
                self._decided(decision)
            except Exception:
                # One slot that fails must not end the schedule for every night after.
                log.exception("scheduled patrol %s failed", decision.entry.patrol)
                self.service.note(f"scheduled patrol {decision.entry.patrol} failed to "
                                  "start: an internal error (see the log)")  # fmt: skip

    def _decided(self, decision: Decision) -> None:
        patrol = decision.entry.patrol
        why = decision.why
        if decision.start:
            reply = self.service.run_scheduled(patrol)
            if reply.ok:
                self.service.note(f"scheduled patrol {patrol} started ({why})")
                return
            why = reply.text
        self.service.note(f"scheduled patrol {patrol} skipped: {why}")
        if self.runs is not None:
            problem = PatrolRunLog(self.runs).skipped(patrol, why)
            if problem is not None:
                self.service.note(f"patrol log: {problem}")

    def _running(self, patrol: str) -> bool:
        mission = self.service.control.mission
        return mission is not None and mission.name == patrol
