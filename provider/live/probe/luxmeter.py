"""``shlight serve --lux SOURCE``: an up-facing lux meter beside the camera, read live.

SOURCE is one of

* a number: a fixed reading in lux (a scene whose light does not change, a test);
* ``mqtt[s]://[USER[:PASS]@]HOST[:PORT]/TOPIC``: the latest payload published on TOPIC, a
  number or a JSON object with a ``lux`` number (what Zigbee2MQTT / Tasmota / ESPHome
  illuminance sensors publish); paho-mqtt in its own thread, the URL and the client (user,
  password, TLS with system trust or ``--lux-ca``) those of ``serve --mqtt``
  (:mod:`provider.live.wire.mqtt_link`). Anyone who can publish on the topic can send
  anything: every payload is read under bounds (:func:`parse_payload`: size, nesting,
  digits, 0 … :data:`MAX_LUX`), a bad one is counted, logged (rate-limited) and dropped, and
  nothing raised reaches paho's network thread (an exception there would end it, and with
  it every later reading);
* ``i2c:BUS[:bh1750|tsl2591][@ADDRESS]``: a BH1750 (default, address 0x23) or TSL2591
  (0x29) on the Raspberry Pi's I²C bus BUS (``/dev/i2c-BUS``) through smbus2 (the
  ``sensors`` extra), polled in its own thread.

The probe asks :meth:`LuxMeter.lux` for every frame: the latest reading no older than
``max_age_s`` (a meter that stopped answering must not hold a stale sun), else None, and
the frame's clipped light stays a reported lower bound. :meth:`LuxMeter.health` is the
meter's part of the probe's ``/healthz`` entry (last reading, its age, refusals, broker).
Sensor protocols, from the data sheets:

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
from ...core.radiometry.photometry import LUX_RANGE, check_physical
from ..wire.mqtt_link import MqttTarget, paho_client, parse_mqtt_url

log = logging.getLogger("shlight.luxmeter")

#: A reading older than this is not used (seconds).
MAX_AGE_S = 10.0
#: The brightest reading taken (lux): the top of hand-held lux meters' range (200,000 lx),
#: the bound every command holds a lux reading to (photometry.LUX_RANGE). The noon sun at
#: sea level gives about 1.2e5 lux (1.3e5 above the atmosphere), so a larger number is a
#: sensor or a publisher gone wrong, not light, and must not reach the clients as a sun.
MAX_LUX = LUX_RANGE[1]
#: The largest MQTT payload read (bytes): a sensor's message (Zigbee2MQTT, Tasmota,
#: ESPHome) with all its other fields is a few hundred bytes.
MAX_PAYLOAD_BYTES = 4096
#: The deepest nesting of JSON objects and arrays read: a sensor's message nests 2-3 deep;
#: Python's json recurses once per level (RecursionError near 1,000).
MAX_DEPTH = 8
#: The longest JSON number read (characters): a double holds 17 significant digits, an
#: exponent and signs; longer (a 401-digit integer) is no reading and overflows a float.
MAX_NUMBER_CHARS = 32
#: Seconds between two log lines about refused readings (each says how many so far): a
#: flood of bad payloads must not flood the log.
LOG_EVERY_S = 10.0
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
        self.readings = 0               # readings taken
        self.errors = 0                 # readings refused (or reads failed)
        self.last_error = ""            # why the last one was refused
        self._logged_at = -math.inf     # when a refusal was last logged (monotonic)
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
        logs once in a while) one that is not a number of lux within 0 … :data:`MAX_LUX`:
        a broken sensor must not close anything."""
        try:
            lux = checked_lux(lux)
        except RefusedReading as exc:
            self.refuse(str(exc))
            return False
        with self._lock:
            self._value, self._at = lux, time.monotonic() if at is None else at
            self._reading_colour = colour
            self.readings += 1
        return True

    def refuse(self, reason: str) -> None:
        """Count a refused reading (or a failed read) and its reason; log it, one line at
        most every :data:`LOG_EVERY_S` seconds, with the count so far."""
        self.errors += 1
        self.last_error = reason
        now = time.monotonic()
        if now - self._logged_at >= LOG_EVERY_S:
            self._logged_at = now
            log.warning("lux meter %s: refused: %s (%d so far)", self.description, reason,
                        self.errors)

    def health(self) -> dict:
        """The meter's part of its probe's /healthz entry: ``state`` (``reading``: its
        latest reading is in use; ``stale``: older than ``max_age_s``, not used;
        ``waiting``: none yet), the last reading's ``lux`` and ``age_s`` (seconds),
        ``readings`` taken, ``rejected`` and ``last_rejection`` (why the last one was
        refused)."""
        with self._lock:
            value, at = self._value, self._at
        age = None if value is None else time.monotonic() - at
        state = ("waiting" if value is None else
                 "reading" if age <= self.max_age_s else "stale")
        health = {"source": self.description, "state": state, "lux": value,
                  "age_s": None if age is None else round(age, 3),
                  "readings": self.readings, "rejected": self.errors,
                  "last_rejection": self.last_error}
        if math.isfinite(self.max_age_s):       # a fixed reading never goes stale
            health["max_age_s"] = self.max_age_s
        return health

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
            self.refuse(str(exc))
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


class RefusedReading(ValueError):
    """A reading (or an MQTT payload) that is not one: its message says why, in a few
    words, for the log and /healthz."""


def checked_lux(value) -> float:
    """``value`` as lux, or :class:`RefusedReading`: a number (not a bool), finite, within
    0 … :data:`MAX_LUX`."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise RefusedReading(f"{_kind(value)} is not a number of lux")
    try:
        lux = float(value)
    except OverflowError:       # an int beyond a double
        raise RefusedReading("a number beyond a double is not a reading") from None
    if not math.isfinite(lux):
        raise RefusedReading(f"{lux} lux is not a reading")
    if lux < 0:
        raise RefusedReading(f"{lux:g} lux is negative")
    if lux > MAX_LUX:
        raise RefusedReading(f"{lux:g} lux is above {MAX_LUX:,.0f}, more than the noon sun "
                             "gives")
    return lux


def _kind(value) -> str:
    """A few words on what a JSON value is, for a refusal (never the value itself: it may
    be megabytes)."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true/false"
    if isinstance(value, str):
        return "a string"
    if isinstance(value, list):
        return "an array"
    if isinstance(value, dict):
        return "an object"
    return f"a {type(value).__name__}"


def _depth(text: str) -> int:
    """The deepest nesting of objects and arrays in JSON text (brackets inside strings do
    not count), without parsing it."""
    depth = deepest = 0
    in_string = escaped = False
    for ch in text:
        if in_string:
            if escaped:
                escaped = False
            elif ch == "\\":
                escaped = True
            elif ch == '"':
                in_string = False
        elif ch == '"':
            in_string = True
        elif ch in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif ch in "]}":
            depth -= 1
    return deepest


def _number(token: str) -> float:
    """json's hook for every number in a payload: refuses one of more than
    :data:`MAX_NUMBER_CHARS` characters before converting it."""
    if len(token) > MAX_NUMBER_CHARS:
        raise RefusedReading(f"a number of {len(token)} characters (at most "
                             f"{MAX_NUMBER_CHARS})")
    number = float(token)
    if not math.isfinite(number):               # 1e400
        raise RefusedReading(f"{token} is beyond a double")
    return number


def _constant(name: str):
    raise RefusedReading(f"{name} is not a number of lux")


_LUX_KEYS = ("lux", "illuminance_lux", "illuminance")
_CCT_KEYS = ("cct", "cct_k", "color_temperature", "colour_temperature")


def parse_payload(payload: bytes) -> tuple[float, tuple[float, float] | None]:
    """``(lux, colour)`` of an MQTT payload: a number, or an object with a ``lux`` number
    (or ``illuminance_lux``, ``illuminance``) and, from a chroma meter, its CCT in kelvin
    (``cct``, ``cct_k``, ``color_temperature`` or ``colour_temperature``) and ``duv``
    (default 0); ``colour`` is ``(CCT, Duv)`` or None. :class:`RefusedReading`, saying why,
    for anything else, checked in order of cost: at most :data:`MAX_PAYLOAD_BYTES` bytes of
    UTF-8, nested at most :data:`MAX_DEPTH` deep, numbers of at most
    :data:`MAX_NUMBER_CHARS` characters (no NaN or Infinity), lux within 0 …
    :data:`MAX_LUX`. A CCT that is not a number within 1,000-25,000 K (or a Duv beyond
    ±0.05) refuses the whole reading: a colour sensor gone wrong must not tint the sun."""
    if len(payload) > MAX_PAYLOAD_BYTES:
        raise RefusedReading(f"a payload of {len(payload):,} bytes (at most "
                             f"{MAX_PAYLOAD_BYTES:,})")
    try:
        text = bytes(payload).decode("utf-8")
    except UnicodeDecodeError:
        raise RefusedReading("a payload that is not UTF-8 text") from None
    if _depth(text) > MAX_DEPTH:
        raise RefusedReading(f"JSON nested more than {MAX_DEPTH} deep")
    try:
        value = json.loads(text, parse_int=_number, parse_float=_number,
                           parse_constant=_constant)
    except RefusedReading:
        raise
    except ValueError:
        raise RefusedReading("a payload that is neither a number nor JSON") from None
    colour = None
    if isinstance(value, dict):
        key = next((k for k in _LUX_KEYS if k in value), None)
        if key is None:
            raise RefusedReading("an object without a lux, illuminance_lux or "
                                 "illuminance number")
        cct = next((value[k] for k in _CCT_KEYS if k in value), None)
        duv = value.get("duv", 0.0)
        value = value[key]
        if cct is not None:
            if not (isinstance(cct, float) and 1000 <= cct <= 25000):
                raise RefusedReading("a CCT that is not a number within 1,000-25,000 K")
            if not (isinstance(duv, float) and abs(duv) <= 0.05):
                raise RefusedReading("a Duv that is not a number within ±0.05")
            colour = (cct, duv)
    return checked_lux(value), colour


class MqttLuxMeter(LuxMeter):
    """The latest number (or JSON ``{"lux": ...}``) published on an MQTT topic
    (``target.prefix``), over the link ``serve --mqtt`` uses (user, password, TLS).
    Connection problems are logged (once per kind) and paho reconnects; the reading then
    goes stale after ``max_age_s``. ``broker`` (``connecting``, ``connected``, ``down``,
    ``refused``) and ``broker_error`` say where the link stands (/healthz)."""

    def __init__(self, target: MqttTarget, ca_file: str | None = None, **kw):
        super().__init__(target.url, **kw)
        self.target, self.topic = target, target.prefix
        self._client = paho_client(target, ca_file, ca_option="--lux-ca")
        self._client.reconnect_delay_set(0.5, 10.0)
        self._client.on_connect = self._on_connect
        self._client.on_connect_fail = self._on_connect_fail
        self._client.on_disconnect = self._on_disconnect
        self._client.on_message = self._on_message
        # A second guard behind _on_message's own: whatever a callback raises is logged by
        # paho, not raised out of its network thread (which would end the meter).
        self._client.suppress_exceptions = True
        self._said = ""
        self.connected = threading.Event()
        self.broker, self.broker_error = "connecting", ""

    def _on_connect(self, client, userdata, flags, reason_code, properties) -> None:
        if reason_code.is_failure:
            self.broker, self.broker_error = "refused", str(reason_code)
            if str(reason_code) != self._said:
                self._said = str(reason_code)
                log.warning("lux meter %s: the broker refused: %s", self.description,
                            reason_code)
            return
        self._said = ""
        client.subscribe(self.topic, qos=0)
        self.broker, self.broker_error = "connected", ""
        self.connected.set()

    def _on_connect_fail(self, client, userdata) -> None:
        self.broker, self.broker_error = "down", "cannot reach the broker"
        if self._said != self.broker_error:
            self._said = self.broker_error
            log.warning("lux meter %s: cannot reach the broker (retrying)", self.description)

    def _on_disconnect(self, client, userdata, flags, reason_code, properties) -> None:
        self.connected.clear()
        if self.broker != "refused":
            self.broker, self.broker_error = "down", f"disconnected: {reason_code}"

    def _on_message(self, client, userdata, msg) -> None:
        # The callback boundary: nothing may escape into paho's thread.
        try:
            self.on_payload(msg.payload)
        except Exception as exc:    # noqa: BLE001 - a bug here must not end the meter
            self.refuse(f"{type(exc).__name__}: {exc}"[:200])

    def on_payload(self, payload: bytes) -> bool:
        """Store a payload's reading (:func:`parse_payload`); a refused one is counted,
        logged (rate-limited) and dropped, and the last good reading stays."""
        try:
            lux, colour = parse_payload(payload)
        except RefusedReading as exc:
            self.refuse(str(exc))
            return False
        return self.set(lux, colour=colour)

    def health(self) -> dict:
        health = super().health()
        health.update(broker=self.broker, broker_error=self.broker_error)
        return health

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
