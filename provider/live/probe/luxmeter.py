"""``shlight serve --lux SOURCE``: an up-facing lux meter beside the camera, read live.

SOURCE is one of

* a number: a fixed reading in lux (a scene whose light does not change, a test);
* ``mqtt[s]://[USER[:PASS]@]HOST[:PORT]/TOPIC``: the latest payload published on TOPIC, a
  number or a JSON object with a ``lux`` number (what Zigbee2MQTT / Tasmota / ESPHome
  illuminance sensors publish); paho-mqtt in its own thread, the URL and the client (user,
  password, TLS with system trust or ``--lux-ca``) those of ``serve --mqtt``
  (:mod:`provider.live.wire.mqtt_link`);
* ``i2c:BUS[:bh1750|tsl2591][@ADDRESS]``: a BH1750 (default, address 0x23) or TSL2591
  (0x29) on the Raspberry Pi's I²C bus BUS (``/dev/i2c-BUS``) through smbus2 (the
  ``sensors`` extra), polled in its own thread.

The probe asks :meth:`LuxMeter.lux` for every frame: the latest reading no older than
``max_age_s`` (a meter that stopped answering must not hold a stale sun), else None, and
the frame's clipped light stays a reported lower bound. Sensor protocols, from the data
sheets:

* BH1750 (ROHM BH1750FVI): opcode 0x01 power on, 0x10 continuous high-resolution mode
  (1 lx, 120 ms); a read returns two bytes, big-endian; lux = count / 1.2 at the default
  measurement time (MTreg 69).
* TSL2591 (ams): every register access is the command byte ``0xA0 | register``; ID (0x12)
  reads 0x50; ENABLE (0x00) ← 0x03 (power on, ALS on); CONTROL (0x01) ← gain and
  integration time; C0DATA (0x14-0x15, full spectrum) and C1DATA (0x16-0x17, infrared),
  little-endian. lux = (C0 − C1)·(1 − C1/C0) / CPL with CPL = ATIME_ms · AGAIN / 408 (the
  device factor of ams's application note as Adafruit's TSL2591 driver uses it).
"""
from __future__ import annotations

import json
import logging
import math
import threading
import time

from ...core.errors import InputError
from ..wire.mqtt_link import MqttTarget, paho_client, parse_mqtt_url

log = logging.getLogger("shlight.luxmeter")

#: A reading older than this is not used (seconds).
MAX_AGE_S = 10.0
#: Seconds between two sensor reads (the BH1750 integrates 120 ms, the TSL2591 100+ ms).
POLL_S = 0.25

BH1750_ADDRESS = 0x23
BH1750_POWER_ON = 0x01
BH1750_CONTINUOUS_HIGH = 0x10

TSL2591_ADDRESS = 0x29
TSL2591_COMMAND = 0xA0
TSL2591_ENABLE, TSL2591_CONTROL, TSL2591_ID = 0x00, 0x01, 0x12
TSL2591_C0DATAL = 0x14
TSL2591_ID_VALUE = 0x50
#: Medium gain (25×), 100 ms: CONTROL = AGAIN << 4 | ATIME.
TSL2591_AGAIN, TSL2591_GAIN_BITS = 25.0, 0x1
TSL2591_ATIME_MS, TSL2591_ATIME_BITS = 100.0, 0x0
TSL2591_LUX_DF = 408.0


class LuxMeter:
    """The latest reading of a meter (thread-safe), no older than ``max_age_s``."""

    def __init__(self, description: str, max_age_s: float = MAX_AGE_S):
        self.description = description
        self.max_age_s = max_age_s
        self._value: float | None = None
        self._at = -math.inf
        self._lock = threading.Lock()
        self.errors = 0
        #: where the meter faces (``--lux-facing``: :func:`provider.core.sh9.meter.parse_facing`;
        #: None: up)
        self.facing = None
        self._fixed_colour = None
        self._reading_colour = None

    @property
    def colour(self) -> tuple[float, float] | None:
        """A chroma meter's (CCT K, Duv) of its latest reading (an MQTT payload's ``cct``),
        else the fixed one (``--lux-cct``), else None (the closed light is neutral)."""
        return self.reading()[1]

    @colour.setter
    def colour(self, value) -> None:
        self._fixed_colour = value

    def set(self, lux: float, at: float | None = None, colour=None) -> bool:
        """Store a reading (and its (CCT, Duv) when the meter says it); refuses (counts,
        logs once in a while) a non-finite or negative one: a broken sensor must not close
        anything."""
        try:
            lux = float(lux)
        except (TypeError, ValueError):
            lux = math.nan
        if not (math.isfinite(lux) and lux >= 0):
            if self._count_error():
                log.warning("lux meter %s: refused reading %r (%d so far)", self.description,
                            lux, self.errors)
            return False
        with self._lock:
            self._value, self._at = lux, time.monotonic() if at is None else at
            self._reading_colour = colour
        return True

    def _count_error(self) -> bool:
        """Count one error; whether to log it (the 1st, 10th, 100th, then every 1000th)."""
        self.errors += 1
        return self.errors in (1, 10, 100) or self.errors % 1000 == 0

    def lux(self) -> float | None:
        """The latest reading in lux, or None (none yet, or older than ``max_age_s``)."""
        return self.reading()[0]

    def reading(self) -> tuple[float | None, tuple[float, float] | None]:
        """``(lux, colour)`` of one reading, taken together (a new MQTT reading may arrive
        between two separate calls): :meth:`lux` and :attr:`colour` of the same moment."""
        with self._lock:
            colour = self._reading_colour or self._fixed_colour
            if self._value is None or time.monotonic() - self._at > self.max_age_s:
                return None, colour
            return self._value, colour

    def start(self) -> None:
        """Start reading (a thread or a client); a fixed meter has nothing to start."""

    def stop(self) -> None:
        """Stop reading."""


class FixedLux(LuxMeter):
    """A reading given once (``--lux 32000``): never stale."""

    def __init__(self, lux: float):
        super().__init__(f"{lux:g} lux", max_age_s=math.inf)
        from ...core.radiometry.photometry import LUX_RANGE, check_physical
        self.set(check_physical("--lux", lux, LUX_RANGE, " lux"))


class PolledLuxMeter(LuxMeter):
    """A sensor read by ``read()`` every ``poll_s`` in its own thread."""

    def __init__(self, description: str, poll_s: float = POLL_S, **kw):
        super().__init__(description, **kw)
        self.poll_s = poll_s
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def read(self) -> float:
        raise NotImplementedError

    def poll_once(self) -> bool:
        """One reading into :meth:`lux` (an I/O error is counted and logged, not raised)."""
        try:
            return self.set(self.read())
        except OSError as exc:
            if self._count_error():
                log.warning("lux meter %s: %s (%d errors so far)", self.description, exc,
                            self.errors)
            return False

    def _run(self) -> None:
        while not self._stop.is_set():
            self.poll_once()
            self._stop.wait(self.poll_s)

    def start(self) -> None:
        self._thread = threading.Thread(target=self._run, name=f"lux {self.description}",
                                        daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)


class BH1750(PolledLuxMeter):
    """A BH1750 on an smbus2-like ``bus`` (``write_byte``, ``read_i2c_block_data``)."""

    def __init__(self, bus, address: int = BH1750_ADDRESS, **kw):
        super().__init__(f"BH1750 at 0x{address:02x}", **kw)
        self.bus, self.address = bus, address
        self.bus.write_byte(address, BH1750_POWER_ON)
        self.bus.write_byte(address, BH1750_CONTINUOUS_HIGH)

    def read(self) -> float:
        hi, lo = self.bus.read_i2c_block_data(self.address, BH1750_CONTINUOUS_HIGH, 2)
        return ((hi << 8) | lo) / 1.2


class TSL2591(PolledLuxMeter):
    """A TSL2591 on an smbus2-like ``bus`` (``read_byte_data``, ``write_byte_data``,
    ``read_i2c_block_data``); refuses a device whose ID is not 0x50."""

    def __init__(self, bus, address: int = TSL2591_ADDRESS, **kw):
        super().__init__(f"TSL2591 at 0x{address:02x}", **kw)
        self.bus, self.address = bus, address
        ident = bus.read_byte_data(address, TSL2591_COMMAND | TSL2591_ID)
        if ident != TSL2591_ID_VALUE:
            raise InputError(f"no TSL2591 at 0x{address:02x} (ID 0x{ident:02x}, expected "
                             f"0x{TSL2591_ID_VALUE:02x})")
        bus.write_byte_data(address, TSL2591_COMMAND | TSL2591_ENABLE, 0x03)
        bus.write_byte_data(address, TSL2591_COMMAND | TSL2591_CONTROL,
                            TSL2591_GAIN_BITS << 4 | TSL2591_ATIME_BITS)

    def read(self) -> float:
        b = self.bus.read_i2c_block_data(self.address, TSL2591_COMMAND | TSL2591_C0DATAL, 4)
        full, ir = b[0] | b[1] << 8, b[2] | b[3] << 8
        if full >= 0xFFFF or ir >= 0xFFFF:
            raise OSError("TSL2591 saturated (too bright for medium gain)")
        if full == 0:
            return 0.0
        cpl = TSL2591_ATIME_MS * TSL2591_AGAIN / TSL2591_LUX_DF
        return max((full - ir) * (1.0 - ir / full) / cpl, 0.0)


def _is_number(v) -> bool:
    return not isinstance(v, bool) and isinstance(v, (int, float)) and math.isfinite(v)


class MqttLuxMeter(LuxMeter):
    """The latest number (or JSON ``{"lux": ...}``) published on an MQTT topic
    (``target.prefix``), over the link ``serve --mqtt`` uses (user, password, TLS).
    Connection problems are logged (once per kind) and paho reconnects; the reading then
    goes stale after ``max_age_s``."""

    def __init__(self, target: MqttTarget, ca_file: str | None = None, **kw):
        super().__init__(target.url, **kw)
        self.target, self.topic = target, target.prefix
        self._client = paho_client(target, ca_file, ca_option="--lux-ca")
        self._client.reconnect_delay_set(0.5, 10.0)
        self._client.on_connect = self._on_connect
        self._client.on_message = lambda c, u, msg: self.on_payload(msg.payload)
        self._said = ""
        self.connected = threading.Event()

    def _on_connect(self, client, userdata, flags, reason_code, properties) -> None:
        if reason_code.is_failure:
            if str(reason_code) != self._said:
                self._said = str(reason_code)
                log.warning("lux meter %s: the broker refused: %s", self.description,
                            reason_code)
            return
        self._said = ""
        client.subscribe(self.topic, qos=0)
        self.connected.set()

    def on_payload(self, payload: bytes) -> bool:
        """Store a payload's reading: a number, or an object with a ``lux`` number (or
        ``illuminance_lux``, ``illuminance``) and, from a chroma meter, its CCT in kelvin
        (``cct``, ``cct_k``, ``color_temperature`` or ``colour_temperature``) and ``duv``
        (default 0). A CCT that is not a number within 1,000-25,000 K (or a Duv beyond
        ±0.05) refuses the whole reading: a colour sensor gone wrong must not tint the sun."""
        try:
            value = json.loads(payload.decode("utf-8", "replace"))
        except ValueError:
            value = None
        colour = None
        if isinstance(value, dict):
            cct = next((value[k] for k in ("cct", "cct_k", "color_temperature",
                                           "colour_temperature") if k in value), None)
            duv = value.get("duv", 0.0)
            value = value.get("lux", value.get("illuminance_lux", value.get("illuminance")))
            if cct is not None:
                if (_is_number(cct) and _is_number(duv) and 1000 <= cct <= 25000
                        and abs(duv) <= 0.05):
                    colour = (float(cct), float(duv))
                else:
                    value = math.nan
        if not _is_number(value):
            value = math.nan
        return self.set(value, colour=colour)

    def start(self) -> None:
        self._client.connect_async(self.target.host, self.target.port)
        self._client.loop_start()

    def stop(self) -> None:
        self._client.disconnect()
        self._client.loop_stop()


def parse_lux_source(text: str, *, bus_factory=None, ca_file: str | None = None) -> LuxMeter:
    """The meter of a ``--lux`` SOURCE (see the module doc); one clear InputError for
    anything else. ``bus_factory(bus_number)``: an smbus2-like bus (tests pass a fake);
    ``ca_file``: ``--lux-ca``, the CA of an ``mqtts://`` broker (else system trust)."""
    text = str(text).strip()
    try:
        number = float(text)
    except ValueError:
        number = None
    if ca_file and not text.startswith("mqtts://"):
        raise InputError("--lux-ca is for --lux mqtts://...")
    if number is not None:
        return FixedLux(number)
    if text.startswith(("mqtt://", "mqtts://")):
        return MqttLuxMeter(parse_mqtt_url(text, "--lux", default_topic=None), ca_file)
    if text.startswith("i2c:"):
        rest, _, addr = text[4:].partition("@")
        bus_text, _, kind = rest.partition(":")
        kind = kind or "bh1750"
        if kind not in ("bh1750", "tsl2591") or not bus_text.isdigit():
            raise InputError(f"--lux {text}: expected i2c:BUS[:bh1750|tsl2591][@ADDRESS]")
        try:
            address = int(addr, 0) if addr else (BH1750_ADDRESS if kind == "bh1750"
                                                else TSL2591_ADDRESS)
        except ValueError:
            raise InputError(f"--lux {text}: the address is not a number (e.g. @0x23)") from None
        if bus_factory is None:
            try:
                from smbus2 import SMBus
            except ImportError:
                raise InputError("--lux i2c:... needs smbus2 (pip install "
                                 "'shlight[sensors]')") from None
            bus_factory = SMBus
        try:
            bus = bus_factory(int(bus_text))
            return (BH1750 if kind == "bh1750" else TSL2591)(bus, address)
        except OSError as exc:
            raise InputError(f"--lux {text}: cannot reach the sensor on /dev/i2c-{bus_text} "
                             f"at 0x{address:02x}: {exc.strerror or exc}") from None
    raise InputError(f"--lux {text}: a number of lux, mqtt[s]://[USER:PASS@]HOST[:PORT]/TOPIC or "
                     "i2c:BUS[:bh1750|tsl2591][@ADDRESS]")
