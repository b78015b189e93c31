"""The Mosquitto deployment of docs/fleet-deployment.md, run for real (issue 28, item 4):
its mosquitto.conf, ACL and scripts (tests/fleet/deployment/, which the page shows) on
127.0.0.1, with certificates and passwords made in a temporary folder by those scripts,
checked with the BrokerLink the robots and master controls use.

A message that must not arrive is judged by a later one that must: one sender's messages
reach a subscriber in order, so once the later one is heard the earlier would have been.
"""

from __future__ import annotations

import contextlib
import getpass
import os
import shutil
import subprocess
import threading
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from giraff_console.fleet.broker_link import MAX_MESSAGE_BYTES, Broker, BrokerLink
from giraff_console.fleet.topics import Topic, VehicleId, every_vehicle
from tests.fleet.broker import Broker as BrokerProcess

TOOLS = ("mosquitto", "mosquitto_passwd", "openssl")
WHY_SKIPPED = ("needs Mosquitto (mosquitto, mosquitto_passwd) and openssl: the deployment's "
               "TLS, passwords and ACLs are Mosquitto's own, which the test extra's amqtt "
               "cannot check")  # fmt: skip

DEPLOYMENT = Path(__file__).parent / "deployment"
PAGE = Path(__file__).parents[2] / "docs" / "fleet-deployment.md"
FILES = ("mosquitto.conf", "acl", "make-certs.sh", "add-user.sh")
ROBOT_A = VehicleId("giraff", "giraff-07")
ROBOT_B = VehicleId("giraff", "giraff-08")
MASTER = "fleet-master"
# The certificate names localhost only, so that 127.0.0.1 can be a name it does not have.
HOST = "localhost"
# A TLS connection on 127.0.0.1 takes milliseconds; these are for a loaded machine.
UP_S = 5.0
HEARD_S = 5.0
# How long a refused client is given to come up once an accepted one, started with it,
# is up: many times what a connection takes here.
REFUSED_S = 0.5
RESEND_S = 0.1


def local_config(text: str, port: int, folder: Path) -> str:
    """The deployment's mosquitto.conf for a test: a free port on 127.0.0.1, its files in
    `folder`, run as whoever runs the test; every other line as the page shows it."""
    changes = {
        "listener 8883\n": f"listener {port} 127.0.0.1\n",
        "user mosquitto\n": f"user {getpass.getuser()}\n",
        "/etc/mosquitto/certs/": f"{folder}/certs/",
        "/etc/mosquitto/": f"{folder}/",
        "/run/mosquitto/": f"{folder}/",
        "/var/lib/mosquitto/": f"{folder}/",
    }
    for old, new in changes.items():
        # Each must still be there: a changed file fails here, not in a puzzling way later.
        assert old in text, f"mosquitto.conf no longer has {old!r}"
        text = text.replace(old, new)
    return text


class DeployedBroker(BrokerProcess):
    """The shared broker process (start, stop, waiting for its port) on our config."""

    def _command(self) -> list[str]:
        config = self.folder / "mosquitto.conf"
        text = (DEPLOYMENT / "mosquitto.conf").read_text(encoding="utf-8")
        config.write_text(local_config(text, self.port, self.folder), encoding="utf-8")
        return ["mosquitto", "-c", str(config)]


@dataclass(frozen=True)
class Deployment:
    port: int
    ca_file: Path
    folder: Path

    def credentials(self, user: str) -> Path:
        return self.folder / f"{user}.cred"

    def broker(self, user: str | None, *, scheme: str = "mqtts", host: str = HOST,
               ca_file: Path | None = None) -> Broker:  # fmt: skip
        return Broker.parse(f"{scheme}://{host}:{self.port}",
                            ca_file=ca_file or self.ca_file,
                            credentials=self.credentials(user) if user else None)  # fmt: skip


def run(*command: str | Path) -> None:
    subprocess.run([str(part) for part in command], check=True, timeout=30,
                   capture_output=True)  # fmt: skip


@pytest.fixture(scope="module")
def deployment(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Deployment]:
    if not all(shutil.which(tool) for tool in TOOLS):
        pytest.skip(WHY_SKIPPED)
    folder = tmp_path_factory.mktemp("fleet-deployment")
    run("sh", DEPLOYMENT / "make-certs.sh", folder / "certs", HOST)
    for user in (ROBOT_A.serial_number, ROBOT_B.serial_number, MASTER):
        run("sh", DEPLOYMENT / "add-user.sh", folder / "passwd", user, folder / f"{user}.cred")
    (folder / "acl").write_text((DEPLOYMENT / "acl").read_text(encoding="utf-8"),
                                encoding="utf-8")  # fmt: skip
    process = DeployedBroker(folder, kind="mosquitto").start()
    try:
        yield Deployment(process.port, folder / "certs" / "ca.crt", folder)
    finally:
        process.stop()


class Inbox:
    """What one link has heard, in order, and whether it ever went down."""

    def __init__(self) -> None:
        self.messages: list[tuple[str, bytes]] = []
        self.downs = 0
        self._changed = threading.Condition()

    def heard(self, topic: str, payload: bytes) -> None:
        with self._changed:
            self.messages.append((topic, payload))
            self._changed.notify_all()

    def connected(self, up: bool) -> None:
        if not up:
            self.downs += 1

    def wait_for(self, topic: str, payload: bytes, timeout: float = HEARD_S) -> bool:
        with self._changed:
            return self._changed.wait_for(lambda: (topic, payload) in self.messages, timeout)

    def until_heard(self, send: Callable[[], object], topic: str, payload: bytes) -> bool:
        """Send again and again until heard: a subscription made at connection may not be
        in place yet when the link says it is up."""
        for _ in range(int(HEARD_S / RESEND_S)):
            send()
            if self.wait_for(topic, payload, RESEND_S):
                return True
        return False

    def payloads(self, topic: str) -> list[bytes]:
        with self._changed:
            return [payload for heard, payload in self.messages if heard == topic]


@contextlib.contextmanager
def link(broker: Broker, client_id: str, subscriptions: tuple[str, ...] = (), *,
         max_bytes: int = MAX_MESSAGE_BYTES) -> Iterator[tuple[BrokerLink, Inbox]]:  # fmt: skip
    """A started link and what it hears; stopped afterwards."""
    inbox = Inbox()
    started = BrokerLink(broker, client_id, heard=inbox.heard, connected=inbox.connected,
                         subscriptions=subscriptions, max_bytes=max_bytes)  # fmt: skip
    started.start()
    try:
        yield started, inbox
    finally:
        started.stop()


@contextlib.contextmanager
def up(broker: Broker, client_id: str, subscriptions: tuple[str, ...] = (), *,
       max_bytes: int = MAX_MESSAGE_BYTES) -> Iterator[tuple[BrokerLink, Inbox]]:  # fmt: skip
    with link(broker, client_id, subscriptions, max_bytes=max_bytes) as (started, inbox):
        assert started.wait_up(UP_S), f"{client_id} did not connect in {UP_S} s"
        yield started, inbox


def master(deployment: Deployment, **options: int) -> contextlib.AbstractContextManager[
        tuple[BrokerLink, Inbox]]:  # fmt: skip
    return up(deployment.broker(MASTER), MASTER, (every_vehicle(Topic.STATE),), **options)


def robot(deployment: Deployment, vehicle: VehicleId,
          subscriptions: tuple[str, ...] = ()) -> contextlib.AbstractContextManager[
        tuple[BrokerLink, Inbox]]:  # fmt: skip
    return up(deployment.broker(vehicle.serial_number), vehicle.serial_number,
              subscriptions or (vehicle.topic(Topic.ORDER),))  # fmt: skip


def heard_by_master(master_inbox: Inbox, sender: BrokerLink, payload: bytes) -> bool:
    topic = ROBOT_A.topic(Topic.STATE)
    return master_inbox.until_heard(lambda: sender.publish(topic, payload), topic, payload)


def refused(deployment: Deployment, broker: Broker) -> bool:
    """Whether a link to `broker` stays down while an accepted one, started with it,
    comes up: so the broker is answering, and answering it no."""
    with link(broker, "refused") as (refused_link, _), \
            up(deployment.broker(ROBOT_B.serial_number), ROBOT_B.serial_number):  # fmt: skip
        return not refused_link.wait_up(REFUSED_S)


@pytest.mark.parametrize("name", FILES)
def test_the_page_shows_the_file_as_it_is(name: str) -> None:
    # Whole, in one piece: the page is what an administrator copies from.
    text = (DEPLOYMENT / name).read_text(encoding="utf-8")
    assert text in PAGE.read_text(encoding="utf-8"), f"{PAGE.name} no longer shows {name}"


def test_the_master_control_hears_a_robots_state(deployment: Deployment) -> None:
    with master(deployment) as (_, heard), robot(deployment, ROBOT_A) as (robot_a, _):
        assert heard_by_master(heard, robot_a, b'{"headerId": 1}')


def test_a_robot_cannot_publish_as_another(deployment: Deployment) -> None:
    with master(deployment) as (_, heard), robot(deployment, ROBOT_A) as (robot_a, _):
        assert heard_by_master(heard, robot_a, b"subscribed")
        robot_a.publish(ROBOT_B.topic(Topic.STATE), b"forged")
        robot_a.publish(VehicleId("other", ROBOT_A.serial_number).topic(Topic.STATE),
                        b"forged")  # fmt: skip
        assert heard_by_master(heard, robot_a, b"after")
    assert [topic for topic, _ in heard.messages] == [ROBOT_A.topic(Topic.STATE)] * len(
        heard.messages
    )


def test_a_robot_cannot_read_another_robots_orders(deployment: Deployment) -> None:
    # B's order topic named outright, and a wildcard that would cover every robot's.
    snooping = (ROBOT_B.topic(Topic.ORDER), every_vehicle(Topic.ORDER), "uagv/#",
                ROBOT_A.topic(Topic.ORDER))  # fmt: skip
    with master(deployment) as (master_link, _), \
            robot(deployment, ROBOT_A, snooping) as (_, heard):  # fmt: skip
        to_a = ROBOT_A.topic(Topic.ORDER)
        assert heard.until_heard(lambda: master_link.publish(to_a, b"subscribed"), to_a,
                                 b"subscribed")  # fmt: skip
        master_link.publish(ROBOT_B.topic(Topic.ORDER), b"for B")
        master_link.publish(to_a, b"after")
        assert heard.wait_for(to_a, b"after")
    assert {payload for _, payload in heard.messages} == {b"subscribed", b"after"}


def test_the_master_controls_order_reaches_its_robot(deployment: Deployment) -> None:
    with master(deployment) as (master_link, _), robot(deployment, ROBOT_A) as (_, heard):
        to_a = ROBOT_A.topic(Topic.ORDER)
        order = b'{"orderId": "kitchen", "orderUpdateId": 0}'
        assert heard.until_heard(lambda: master_link.publish(to_a, order), to_a, order)


def test_a_wrong_password_is_refused(deployment: Deployment) -> None:
    wrong = deployment.folder / "wrong.cred"
    wrong.write_text(f"{ROBOT_A.serial_number}:not-the-password\n", encoding="utf-8")
    os.chmod(wrong, 0o600)
    broker = Broker.parse(f"mqtts://{HOST}:{deployment.port}", ca_file=deployment.ca_file,
                          credentials=wrong)  # fmt: skip
    assert refused(deployment, broker)


def test_anonymous_is_refused(deployment: Deployment) -> None:
    assert refused(deployment, deployment.broker(None))


def test_plain_mqtt_to_the_tls_port_fails(deployment: Deployment) -> None:
    assert refused(deployment, deployment.broker(ROBOT_A.serial_number, scheme="mqtt"))


def test_a_message_over_the_size_limit_is_not_forwarded(deployment: Deployment) -> None:
    # The master's own limit is lifted, so that only the broker's can drop it.
    with master(deployment, max_bytes=4 * MAX_MESSAGE_BYTES) as (master_link, heard), \
            robot(deployment, ROBOT_A) as (robot_a, _):  # fmt: skip
        state = ROBOT_A.topic(Topic.STATE)
        assert heard_by_master(heard, robot_a, b"subscribed")
        robot_a.publish(state, b"x" * MAX_MESSAGE_BYTES)
        robot_a.publish(state, b"y" * (MAX_MESSAGE_BYTES + 1))
        assert heard_by_master(heard, robot_a, b"after")
        assert master_link.dropped == 0
    sizes = [len(payload) for payload in heard.payloads(state)]
    assert sizes == [len(b"subscribed"), MAX_MESSAGE_BYTES, len(b"after")]


def test_the_broker_must_be_named_in_its_certificate(deployment: Deployment) -> None:
    # The certificate names localhost; 127.0.0.1 is the same broker under a name it lacks.
    assert refused(deployment, deployment.broker(ROBOT_A.serial_number, host="127.0.0.1"))


def test_a_broker_signed_by_another_ca_is_refused(deployment: Deployment) -> None:
    other = deployment.folder / "other-ca"
    run("sh", DEPLOYMENT / "make-certs.sh", other, HOST)
    broker = deployment.broker(ROBOT_A.serial_number, ca_file=other / "ca.crt")
    assert refused(deployment, broker)


def test_a_robot_cannot_take_another_robots_client_id(deployment: Deployment) -> None:
    with master(deployment) as (master_link, _), robot(deployment, ROBOT_B) as (_, heard_b):
        to_b = ROBOT_B.topic(Topic.ORDER)
        assert heard_b.until_heard(lambda: master_link.publish(to_b, b"subscribed"), to_b,
                                   b"subscribed")  # fmt: skip
        # A's client asks for B's client id; the broker gives it A's user name instead.
        with up(deployment.broker(ROBOT_A.serial_number), ROBOT_B.serial_number):
            # Taken over, B would be off the broker by now (A is up), and miss this.
            master_link.publish(to_b, b"after")
            assert heard_b.wait_for(to_b, b"after")
            assert heard_b.downs == 0
