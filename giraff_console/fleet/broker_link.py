"""One connection to an MQTT broker (paho-mqtt), for a vehicle or a master control:
where the broker is, TLS and credentials, a last will, subscriptions made again at every
connection, and reconnection by paho's own thread when the broker comes back.

What arrives is handed on as (topic, bytes); a message over `max_bytes` is dropped and
counted, never parsed. paho reads a message whole before we see it, so the broker's own
limit (`message_size_limit` in docs/fleet-deployment.md's mosquitto.conf) is what keeps
one from being allocated at all; this one keeps it from going further.
"""

from __future__ import annotations

import contextlib
import ssl
import threading
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from urllib.parse import urlsplit

import paho.mqtt.client as mqtt

from giraff_console.file_limits import read_bounded

# A message larger than any VDA 5050 message this robot handles: an order of 200 nodes
# and edges, each with a few actions, is well under it.
MAX_MESSAGE_BYTES = 256 * 1024
KEEPALIVE_S = 5
# paho waits this long, doubling from RECONNECT_MIN_S, between tries while the broker is
# away (whole seconds: paho's own unit).
RECONNECT_MIN_S = 1
RECONNECT_MAX_S = 4
DEFAULT_PORTS = {"mqtt": 1883, "mqtts": 8883}


class BrokerError(ValueError):
    """A broker URL, certificate or credentials file that cannot be used."""


@dataclass(frozen=True)
class Broker:
    """Where the broker is: `mqtt://HOST[:PORT]` or `mqtts://HOST[:PORT]` (TLS), with the
    CA that signed its certificate (None: the system's) and a file of `user:password`."""

    host: str
    port: int
    tls: bool = False
    ca_file: Path | None = None
    credentials: Path | None = None

    @classmethod
    def parse(
        cls, url: str, *, ca_file: Path | None = None, credentials: Path | None = None
    ) -> Broker:
        parts = urlsplit(url)
        if parts.scheme not in DEFAULT_PORTS or not parts.hostname:
            raise BrokerError(
                f"the broker is mqtt://HOST[:PORT] or mqtts://HOST[:PORT], not {url!r}"
            )
        if parts.username or parts.password or parts.path not in ("", "/") or parts.query:
            raise BrokerError(
                f"{url!r}: only a host and a port; credentials go in a file "
                "(the credentials setting), never on a command line"
            )
        try:
            port = parts.port or DEFAULT_PORTS[parts.scheme]
        except ValueError:
            raise BrokerError(f"{url!r}: the port is not a number from 1 to 65535") from None
        return cls(parts.hostname, port, parts.scheme == "mqtts", ca_file, credentials)

    def login(self) -> tuple[str, str] | None:
        """The user and password from the credentials file (one line `user:password`),
        which only its owner may read; BrokerError otherwise."""
        if self.credentials is None:
            return None
        path = self.credentials
        try:
            if path.stat().st_mode & 0o077:
                raise BrokerError(f"{path}: others may read it; chmod 600 {path}")
            # Bounded and by type (file_limits.py): a FIFO would hang the daemon's start.
            text = read_bounded(path).decode("utf-8")
            user, colon, password = text.strip().partition(":")
        except (OSError, UnicodeDecodeError) as error:
            raise BrokerError(f"{path}: {error}") from None
        if not colon or not user or "\n" in password:
            raise BrokerError(f"{path}: one line, user:password")
        return user, password


class BrokerLink:
    """A client of the broker. `heard(topic, payload)` and `connected(up)` are called on
    paho's thread: they must be quick and must not raise."""

    def __init__(
        self,
        broker: Broker,
        client_id: str,
        *,
        heard: Callable[[str, bytes], None] = lambda topic, payload: None,
        connected: Callable[[bool], None] = lambda up: None,
        subscriptions: tuple[str, ...] = (),
        will: tuple[str, Callable[[], bytes]] | None = None,
        max_bytes: int = MAX_MESSAGE_BYTES,
    ) -> None:
        self.broker = broker
        self.max_bytes = max_bytes
        self.dropped = 0  # messages over max_bytes
        self.refusal: str | None = None  # why the broker last said no, in paho's words
        self._heard = heard
        self._connected = connected
        self._subscriptions = subscriptions
        self._up = threading.Event()
        client = mqtt.Client(
            mqtt.CallbackAPIVersion.VERSION2, client_id=client_id, protocol=mqtt.MQTTv311
        )
        client.reconnect_delay_set(RECONNECT_MIN_S, RECONNECT_MAX_S)
        login = broker.login()
        if login is not None:
            client.username_pw_set(*login)
        if broker.tls:
            try:
                # Read as every file of ours is (file_limits.py), not by OpenSSL, which
                # would wait on a FIFO or read /dev/zero for ever.
                ca = broker.ca_file
                authorities = read_bounded(ca).decode("ascii") if ca is not None else None
                context = ssl.create_default_context(cadata=authorities)
            except (OSError, UnicodeDecodeError, ssl.SSLError) as error:
                raise BrokerError(f"{broker.ca_file}: {error}") from None
            client.tls_set_context(context)
        self._will = will
        client.on_connect = self._on_connect
        client.on_disconnect = self._on_disconnect
        client.on_message = self._on_message
        client.on_subscribe = self._on_subscribe
        self._subscribing: int | None = None
        self._client = client

    @property
    def up(self) -> bool:
        return self._up.is_set()

    def start(self) -> None:
        """Connect in the background; paho tries again until the broker answers."""
        self._set_will()
        self._client.connect_async(self.broker.host, self.broker.port, keepalive=KEEPALIVE_S)
        self._client.loop_start()

    def wait_up(self, timeout: float) -> bool:
        return self._up.wait(timeout)

    def publish(self, topic: str, payload: bytes, *, retain: bool = False, qos: int = 0) -> bool:
        """Send it if connected (paho queues nothing for later otherwise); False if not."""
        if not self._up.is_set():
            return False
        info = self._client.publish(topic, payload, qos=qos, retain=retain)
        return info.rc == mqtt.MQTT_ERR_SUCCESS

    def stop(self, last: tuple[str, bytes] | None = None, timeout: float = 2.0) -> None:
        """Say `last` (retained, QoS 1: a vehicle's OFFLINE) if connected, then hang up."""
        if last is not None and self._up.is_set():
            info = self._client.publish(last[0], last[1], qos=1, retain=True)
            # RuntimeError, ValueError: not queued, the connection went meanwhile.
            with contextlib.suppress(RuntimeError, ValueError):
                info.wait_for_publish(timeout)
        self._client.disconnect()
        self._client.loop_stop()

    def _on_connect(
        self,
        client: mqtt.Client,
        userdata: object,
        flags: object,
        reason: mqtt.ReasonCode,
        properties: object,
    ) -> None:
        if reason.is_failure:
            # A refused login looks like a broker away unless it is said (paho tries
            # again, and the vehicle notes why).
            self.refusal = str(reason)
            self._set_will()
            return
        self.refusal = None
        if not self._subscriptions:
            self._now_up()
            return
        # Up once the broker has taken the subscriptions (its SUBACK): a vehicle that says
        # ONLINE before may miss an order sent at once (seen with amqtt).
        self._subscribing = client.subscribe([(topic, 0) for topic in self._subscriptions])[1]

    def _on_subscribe(
        self, client: mqtt.Client, userdata: object, mid: int, reasons: object, properties: object
    ) -> None:
        if mid == self._subscribing:
            self._now_up()

    def _now_up(self) -> None:
        self._up.set()
        self._connected(True)

    def _on_disconnect(
        self,
        client: mqtt.Client,
        userdata: object,
        flags: object,
        reason: mqtt.ReasonCode,
        properties: object,
    ) -> None:
        self._set_will()  # for paho's next try
        if self._up.is_set():
            self._up.clear()
            self._connected(False)

    def _set_will(self) -> None:
        """The last will for the next connection, made now (a vehicle's is stamped with
        the time and its own headerId): QoS 1 and retained, as VDA 5050 asks of
        `connection` (§6.14)."""
        if self._will is not None:
            self._client.will_set(self._will[0], self._will[1](), qos=1, retain=True)

    def _on_message(self, client: mqtt.Client, userdata: object, message: mqtt.MQTTMessage) -> None:
        if len(message.payload) > self.max_bytes:
            self.dropped += 1
            return
        self._heard(message.topic, bytes(message.payload))
