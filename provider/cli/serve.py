"""``shlight serve``: its command-line options, and building the server from them."""
from __future__ import annotations

import argparse
import dataclasses
import asyncio
import logging
import math
import os
import re
import shlex

from ..core.errors import InputError
from ..core.radiometry.image_size import DEFAULT_MAX_PIXELS
from .options import (MAX_FPS, Parser, add_budget_argument, add_engine_arguments,
                      add_table_cache_argument, check_meter_arguments, engine_options)

EPILOG = """\
sources (--source SPEC, or --probe NAME=SPEC, repeatable):
  demo                          built-in animated scene (the default)
  PATH.exr|.hdr|.png|.jpg       an image, re-read when the file changes
  'DIR/*.exr' | DIR             an image sequence at --fps (default 1), looped
  PATH.mp4|.avi|...             a video file, looped (--no-loop: once)
  0 | camera:0 | /dev/video0    a camera (Ricoh Theta S in USB live mode: dual fisheye,
                                --projection dual-fisheye --capture-size 1280x720)
  picamera2[:N]                 a Raspberry Pi camera (Picamera2)
  http://HOST/stream.mjpg       MJPEG over HTTP, or a JPEG snapshot URL
  rtsp://... | opencv:TARGET    anything cv2.VideoCapture opens (FFmpeg)
  theta://[USER:PASS@]HOST      Ricoh Theta over Wi-Fi (OSC live preview; ?api=2.0|2.1)
  ws://HOST:8765/?probe=NAME    relay another shlight serve (edge device -> PC)

examples:
  shlight serve                                      # demo, ws://127.0.0.1:8765/
  shlight serve --source theta://192.168.1.1 --host 0.0.0.0 --token SECRET
  shlight serve --probe room=theta://192.168.1.1 --probe desk=0 \\
                --probe-args "desk=--projection fisheye --fov 190"
  shlight serve --source picamera2 --camera camera.json --bracket   # -9,-6,-3,0,+3 EV

radiometry (8-bit cameras): --camera CAMERA.json (from shlight calibrate-response) decodes
frames with the camera's own curve; a source that reports its exposure (picamera2; a UVC
camera with --exposure-unit; a Theta in manual mode) is divided by it, so auto exposure does
not make the lighting jump; --bracket cycles the exposure (picamera2, UVC, theta://) and
merges the newest frame of every exposure, sending an update every frame.
"""


class _ProbeArgsParser(Parser):
    def error(self, message):
        raise InputError(f"--probe-args: {message}")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The ``shlight serve`` options (the engine options are shared with compute and bench)."""
    from ..live.server.service import DEFAULT_PORT
    parser.description = "Serve live SH9 lighting over WebSocket, with a dashboard on HTTP."
    parser.epilog = EPILOG
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    src = parser.add_argument_group("sources")
    src.add_argument("--source", default=None, metavar="SPEC",
                     help="source of the probe named 'default' (default: demo)")
    src.add_argument("--probe", action="append", default=[], metavar="NAME=SPEC",
                     help="a named probe (repeatable)")
    src.add_argument("--probe-args", action="append", default=[], metavar="NAME=ARGS",
                     help="per-probe options overriding the global ones, e.g. "
                          "\"desk=--projection fisheye --fov 190\" (repeatable)")
    _add_source_arguments(src)
    net = parser.add_argument_group("network and safety")
    net.add_argument("--host", default="127.0.0.1",
                     help="address to bind (default 127.0.0.1; 0.0.0.0 for a LAN)")
    net.add_argument("--port", type=int, default=DEFAULT_PORT,
                     help=f"port for WebSocket and HTTP (default {DEFAULT_PORT}; 0: any free)")
    net.add_argument("--token", default=os.environ.get("SHLIGHT_TOKEN") or None,
                     help="secret clients must present (?token= or Authorization: Bearer); "
                          "default: $SHLIGHT_TOKEN")
    net.add_argument("--allow-origin", action="append", default=[], metavar="ORIGIN",
                     help="extra browser Origin allowed to connect, e.g. "
                          "https://example.org ('*': any; the dashboard's own is always allowed)")
    net.add_argument("--allow-host", action="append", default=[], metavar="NAME",
                     help="a Host name clients may use beyond IP addresses, localhost and "
                          "this machine's name, e.g. lights.example ('.example.org': it and "
                          "its subdomains; '*': any). Others get HTTP 421 (DNS rebinding)")
    net.add_argument("--max-clients", type=int, default=500,
                     help="default 500 (fewer if the open-files limit cannot hold them)")
    net.add_argument("--client-max-rate", type=float, default=20.0, metavar="MSGS",
                     help="messages a second a client may send, after a burst of 2.5 s worth "
                          "(pings included); beyond it they are dropped, and a client that "
                          "goes on is closed with 1008 (default 20)")
    net.add_argument("--connect-rate", type=float, default=2.0, metavar="N",
                     help="WebSocket connections a second one address may open, after a "
                          "burst of 10 s worth (at least 10); beyond, a handshake waits "
                          "its turn (at most 2 s, 4 at once), then HTTP 429 with "
                          "Retry-After. 127.0.0.1 and ::1 are not limited; 0: no limit "
                          "(default 2)")
    net.add_argument("--max-message-bytes", type=int, default=4096,
                     help="larger client messages close the connection with 1009 (default 4096)")
    net.add_argument("--send-timeout", type=float, default=10.0,
                     help="disconnect a client that does not read for this long (default 10 s)")
    net.add_argument("--max-hz", type=float, default=0.0,
                     help="cap on messages per second per client and probe (default: none)")
    net.add_argument("--deflate", action="store_true",
                     help="offer permessage-deflate compression (costs CPU per client)")
    net.add_argument("--tls-cert", metavar="FILE", default=None,
                     help="serve wss:// and https:// with this PEM certificate (chain)")
    net.add_argument("--tls-key", metavar="FILE", default=None,
                     help="the certificate's private key (PEM; unencrypted)")
    net.add_argument("--mqtt", metavar="URL", default=None,
                     help="also publish every probe's messages to an MQTT broker: "
                          "mqtt://[USER:PASS@]HOST[:PORT]/PREFIX or mqtts://... (topic "
                          "PREFIX/PROBE, retained, QoS 0)")
    net.add_argument("--mqtt-ca", metavar="FILE", default=None,
                     help="mqtts://: trust this CA certificate (PEM) instead of the system's")
    from .register import add_serve_arguments
    add_serve_arguments(parser)
    tmp = parser.add_argument_group("temporal behaviour")
    _add_temporal_arguments(tmp)
    _add_environment_arguments(parser.add_argument_group("reflections (docs/contract.md §12)"))
    parser.add_argument("--log-level", default="info",
                        choices=["debug", "info", "warning", "error"])
    add_engine_arguments(parser)
    add_table_cache_argument(parser)
    pt = parser.add_argument_group("passthrough (docs/passthrough.md)")
    pt.add_argument("--passthrough", action="store_true",
                    help="open the WebSocket route /capture (same port, token, TLS, origin "
                         "checks and limits): a headset sends view messages, each followed "
                         "by its JPEG, and gets its passthrough camera's exposure, white "
                         "balance and curve fitted against the probe's sphere")
    pt.add_argument("--passthrough-max-jpeg-bytes", type=int, default=1 << 20, metavar="N",
                    help="a larger view JPEG is answered with an error (default 1048576)")
    pt.add_argument("--passthrough-hz", type=float, default=10.0, metavar="HZ",
                    help="views fitted a second per headset; the others are answered "
                         "\"dropped\" (default 10; 0: every view the workers keep up with)")
    pt.add_argument("--passthrough-max-views", type=int, default=48, metavar="N",
                    help="views each headset's fit keeps, the newest (default 48)")
    pt.add_argument("--passthrough-headsets", type=int, default=4, metavar="N",
                    help="headsets on /capture at once (default 4)")
    pt.add_argument("--passthrough-sphere-every", type=float, default=5.0, metavar="SECONDS",
                    help="a headset's next views are compared with the probe's newest frame "
                         "once it is at least this old a sphere (default 5; 0: every new "
                         "frame); views already fitted keep the sphere of their time")


def _add_source_arguments(g) -> None:
    g.add_argument("--lux", default=None, metavar="SOURCE",
                   help="an up-facing lux meter at the camera closes the clipped sun "
                        "(docs/photometry.md; needs --camera with an absolute scale): a "
                        "number of lux, mqtt[s]://[USER:PASS@]HOST[:PORT]/TOPIC (a number or "
                        "{\"lux\": N}), "
                        "or i2c:BUS[:bh1750|tsl2591][@ADDRESS] (smbus2)")
    g.add_argument("--lux-ca", metavar="FILE", default=None,
                   help="with --lux mqtts://...: the broker's CA certificate (PEM); default: "
                        "the system's trust store")
    from .compute import add_meter_arguments
    add_meter_arguments(g)
    g.add_argument("--fps", type=float, default=None,
                   help="pace of demo/file sources, polling rate of snapshot URLs, most "
                        "messages a second a ws:// relay takes (default 30; at most "
                        f"{MAX_FPS:g})")
    g.add_argument("--no-loop", action="store_true", help="play videos and sequences once")
    g.add_argument("--source-timeout", type=float, default=5.0,
                   help="connect/read timeout of network sources; twice this without a "
                        "frame means hung: reconnect (default 5 s)")
    g.add_argument("--reconnect-max", type=float, default=10.0,
                   help="longest wait between reconnection attempts (backoff from 0.5 s; "
                        "default 10 s)")
    g.add_argument("--capture-size", metavar="WxH", default=None, type=_size,
                   help="cameras: requested frame size, e.g. 1280x720")
    g.add_argument("--capture-fourcc", metavar="CODE", default=None,
                   help="cameras: requested pixel format, e.g. MJPG")
    g.add_argument("--theta-api", choices=["auto", "2.0", "2.1"], default="auto",
                   help="Theta OSC API: 2.1 camera.getLivePreview, 2.0 _getLivePreview "
                        "(auto: try 2.1, fall back to 2.0)")
    g.add_argument("--theta-option", action="append", default=[], type=_theta_option,
                   metavar="NAME=VALUE",
                   help="an OSC option the Theta is set to at every connection and set to "
                        "again when it has lost it (sleep, power cycle), e.g. "
                        "whiteBalance=daylight, iso=200, exposureProgram=1, "
                        "'previewFormat={\"width\":1024,\"height\":512,\"framerate\":8}' "
                        "(VALUE: JSON, or a word); repeatable")
    g.add_argument("--theta-check", type=float, default=30.0, metavar="SECONDS",
                   help="how often the Theta's settings, battery and temperature are checked "
                        "(default 30 s)")
    g.add_argument("--bracket", nargs="?", const="-9,-6,-3,0,3", default=None, type=_offsets,
                   metavar="EVS",
                   help="cycle the exposure over these EV offsets around auto exposure and "
                        "merge the newest frame of each, e.g. -4,-2,0,2,4 (alone: -9,-6,-3,0,3, "
                        "measured best; picamera2, UVC cameras with --exposure-unit, theta://)")
    add_budget_argument(g, DEFAULT_MAX_PIXELS,
                        "one log line, counted in /healthz and /metrics; a file is not read "
                        "again until it changes")
    g.add_argument("--exposure-unit", choices=["100us", "log2s", "s"], default=None,
                   help="UVC cameras: the unit of the driver's CAP_PROP_EXPOSURE (V4L2: "
                        "100us; DirectShow/MSMF: log2s). Without it the exposure OpenCV "
                        "reports is not used (its unit differs by back end)")


#: Theta options a bracket sets itself (it would fight a fixed value).
_BRACKET_OPTIONS = ("exposureProgram", "shutterSpeed", "iso")


#: How deep a --theta-option value may nest: OSC's deepest option (previewFormat, an
#: object in a list of choices) has 2 levels.
THETA_OPTION_DEPTH = 4
#: Longest wait (s) between checks of a Theta's settings (--theta-check): a camera that
#: slept or was switched off and lost them is set again within it.
THETA_CHECK_MAX_S = 3600.0


def _theta_option(text: str) -> tuple:
    """``NAME=VALUE`` -> (NAME, VALUE): strict JSON (finite numbers, at most
    THETA_OPTION_DEPTH levels) where VALUE starts as JSON does (a digit, '-', '{', '[',
    '"'), true, false and null; else the word, sent as a string. NaN and Infinity are
    refused in any spelling: no camera reads them."""
    from ..core.json_text import parse_json
    name, sep, value = text.partition("=")
    name, value = name.strip(), value.strip()
    if not sep or not name or not value:
        raise argparse.ArgumentTypeError(f"{text!r}: expected NAME=VALUE, e.g. whiteBalance=daylight")
    if value.lower().lstrip("+-") in ("nan", "inf", "infinity"):
        raise argparse.ArgumentTypeError(f"{name}={value}: not a number a camera reads "
                                         "(OSC values are JSON, whose numbers are finite)")
    if value[0] in '{["-0123456789' or value in ("true", "false", "null"):
        try:
            return name, parse_json(value, f"{name}={value[:40]}", THETA_OPTION_DEPTH)
        except InputError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None
    return name, value


def _add_temporal_arguments(g) -> None:
    g.add_argument("--smoothing", type=float, default=0.0, metavar="SECONDS",
                   help="time constant of exponential smoothing (default 0: off)")
    g.add_argument("--snap", type=float, default=0.1, metavar="FRACTION",
                   help="a change larger than this (relative RMS irradiance) bypasses "
                        "smoothing and reaches clients at once (default 0.1)")
    g.add_argument("--change-threshold", type=float, default=0.002, metavar="FRACTION",
                   help="lighting that changed less than this is not resent at frame rate "
                        "(default 0.002; 0: send every frame)")
    g.add_argument("--keepalive", type=float, default=1.0, metavar="SECONDS",
                   help="resend unchanged or stale lighting this often (default 1 s)")
    g.add_argument("--stale-after", type=float, default=2.0, metavar="SECONDS",
                   help="mark lighting stale after this long without a frame (default 2 s)")


def _add_environment_arguments(g) -> None:
    g.add_argument("--environment", action="store_true",
                   help="also make an HDR reflection cube (GGX-prefiltered mips) per probe, "
                        "from the same frames as SH9 but in its own thread: GET "
                        "/environment.ktx2, WebSocket subscribe {\"environment\": true}, MQTT "
                        "PREFIX/PROBE/environment")
    g.add_argument("--environment-size", type=_environment_size, default=None, metavar="N",
                   help="edge of a cube face in texels: a power of two from 8 to 256 (default 32)")
    g.add_argument("--environment-hz", type=_environment_hz, default=None, metavar="HZ",
                   help="at most this many cube updates per second, only when the lighting "
                        "changed (default 1)")


def _environment_size(text: str) -> int:
    from ..live.reflections.cube import check_size
    try:
        return check_size(int(text))
    except (InputError, ValueError):
        raise argparse.ArgumentTypeError(f"{text!r}: a power of two from 8 to 256") from None


def _environment_hz(text: str) -> float:
    from ..live.reflections.cube import check_hz
    try:
        return check_hz(float(text))
    except (InputError, ValueError):
        raise argparse.ArgumentTypeError(f"{text!r}: updates per second in (0, 30]") from None


def _offsets(text: str) -> tuple[float, ...]:
    from ..core.radiometry.bracket import check_offsets
    try:
        return check_offsets(text.replace("\u2212", "-").split(","))
    except (InputError, ValueError) as exc:
        raise argparse.ArgumentTypeError(f"EV offsets such as -4,-2,0,2,4: {exc}")


def _size(text: str) -> tuple[int, int]:
    m = re.fullmatch(r"\s*(\d+)\s*[xX×]\s*(\d+)\s*", text)
    if not m or int(m.group(1)) < 1 or int(m.group(2)) < 1:
        raise argparse.ArgumentTypeError("expected WIDTHxHEIGHT, e.g. 1280x720")
    return int(m.group(1)), int(m.group(2))


def _probe_parser() -> argparse.ArgumentParser:
    p = _ProbeArgsParser(prog="--probe-args NAME=", add_help=False)
    _add_source_arguments(p)
    _add_temporal_arguments(p)
    _add_environment_arguments(p)
    add_engine_arguments(p)
    return p


def _split_assignment(text: str, what: str) -> tuple[str, str]:
    from ..live.server.service import PROBE_NAME
    name, sep, value = text.partition("=")
    name = name.strip()
    if sep and name and not value.strip() and what == "--probe":
        raise InputError(f"--probe {text!r}: the source is empty (an unset variable in a "
                         f"service file?): give {name}=SPEC, e.g. {name}=demo")
    if not sep or not value.strip():
        raise InputError(f"{what}: expected NAME=VALUE, got {text!r}")
    if not PROBE_NAME.fullmatch(name):
        raise InputError(f"{what}: probe names are letters, digits, '_', '.', '-' "
                         f"(at most 64), got {name!r}")
    return name, value.strip()


def _check_numbers(ns, where: str = "") -> None:
    checks = [("--keepalive", ns.keepalive, ns.keepalive > 0),
              ("--stale-after", ns.stale_after, ns.stale_after > 0),
              ("--smoothing", ns.smoothing, ns.smoothing >= 0),
              ("--snap", ns.snap, ns.snap > 0),
              ("--change-threshold", ns.change_threshold, ns.change_threshold >= 0),
              ("--source-timeout", ns.source_timeout, ns.source_timeout > 0),
              ("--reconnect-max", ns.reconnect_max, ns.reconnect_max > 0),
              ("--theta-check", ns.theta_check, 0 < ns.theta_check <= THETA_CHECK_MAX_S),
              ("--fps", ns.fps, ns.fps is None or 0 < ns.fps <= MAX_FPS),
              ("--exposure", ns.exposure, ns.exposure > 0),
              ("--downsample", ns.downsample, ns.downsample >= 1)]
    for flag, value, ok in checks:
        if not ok or (isinstance(value, float) and not math.isfinite(value)):
            if flag == "--fps":
                raise InputError(f"{where}--fps {value:g}: out of range (0, {MAX_FPS:g}] "
                                 "frames a second")
            if flag == "--theta-check":
                raise InputError(f"{where}--theta-check {value}: out of range (0, "
                                 f"{THETA_CHECK_MAX_S:g}] seconds (a Theta that lost its "
                                 "settings is set again at the next check)")
            raise InputError(f"{where}{flag} {value}: out of range")


def build_server(args):
    """A :class:`~provider.live.server.service.ProviderServer` from parsed ``shlight serve``
    arguments (not started)."""
    from ..live.reflections.cube import EnvironmentSettings
    from ..live.probe.pipeline import Probe, TemporalSettings
    from ..live.server.service import ProviderServer, ServeSettings
    from ..live.sources import SourceOptions, parse_source
    from ..live.server.tls import server_context
    named = [_split_assignment(t, "--probe") for t in args.probe]
    if args.source is not None and not args.source.strip():
        raise InputError("--source is empty (an unset variable in a service file?): give a "
                         "source, e.g. --source demo")
    if args.source is not None or not named:
        named.insert(0, ("default", args.source or "demo"))
    names = [n for n, _ in named]
    duplicates = {n for n in names if names.count(n) > 1}
    if duplicates:
        raise InputError(f"probe names must be unique: {', '.join(sorted(duplicates))}")
    overrides, given = {}, {}
    for text in args.probe_args:
        name, value = _split_assignment(text, "--probe-args")
        if name not in names:
            raise InputError(f"--probe-args: no probe named {name!r} (probes: {', '.join(names)})")
        try:
            words = shlex.split(value)
        except ValueError as exc:
            raise InputError(f"--probe-args {name}: {exc}") from None
        overrides[name] = _probe_parser().parse_args(words, namespace=argparse.Namespace(**vars(args)))
        given[name] = _given(words)
    for ns in (args, *overrides.values()):
        # A file's OpenEXR header says its projection, per probe (_source_projection); the
        # options are checked meanwhile against an equirect (what live sources are).
        if getattr(ns, "projection", None) == "auto":
            ns.projection, ns._auto_projection = "equirect", True
    _check_option_use(args, [n for n, _ in named], overrides, given)
    s = ServeSettings(host=args.host, port=args.port, token=args.token,
                      allowed_origins=tuple(args.allow_origin), max_clients=args.max_clients,
                      max_message_bytes=args.max_message_bytes, send_timeout=args.send_timeout,
                      max_hz=args.max_hz, deflate=args.deflate,
                      tls=server_context(args.tls_cert, args.tls_key),
                      allowed_hosts=tuple(args.allow_host),
                      client_frame_rate=args.client_max_rate,
                      client_frame_burst=max(2.5 * args.client_max_rate, 10.0),
                      connect_rate=args.connect_rate,
                      connect_burst=max(10.0 * args.connect_rate, 10.0))
    if not 0 < s.client_frame_rate < math.inf:
        raise InputError(f"--client-max-rate {s.client_frame_rate}: out of range (> 0)")
    if not 0 <= s.connect_rate < math.inf:
        raise InputError(f"--connect-rate {s.connect_rate}: out of range (>= 0; 0: no limit)")
    if not (0 <= s.port <= 65535):
        raise InputError(f"--port {s.port}: out of range")
    if (s.max_clients < 1 or s.max_message_bytes < 256 or not 0 < s.send_timeout < math.inf
            or not 0 <= s.max_hz < math.inf):
        raise InputError("--max-clients >= 1, --max-message-bytes >= 256, --send-timeout > 0 "
                         "and --max-hz >= 0 are required (finite numbers)")
    if args.passthrough:
        from ..live.probe.passthrough import PassthroughSettings
        if not (args.passthrough_max_jpeg_bytes >= 1024 and 0 <= args.passthrough_hz < math.inf
                and args.passthrough_max_views >= 4 and args.passthrough_headsets >= 1
                and 0 <= args.passthrough_sphere_every < math.inf):
            raise InputError("--passthrough-max-jpeg-bytes >= 1024, --passthrough-hz >= 0, "
                             "--passthrough-max-views >= 4, --passthrough-headsets >= 1 "
                             "and --passthrough-sphere-every >= 0 are required")
        s.passthrough = PassthroughSettings(
            max_jpeg_bytes=args.passthrough_max_jpeg_bytes, hz=args.passthrough_hz,
            max_views=args.passthrough_max_views, max_headsets=args.passthrough_headsets,
            sphere_every_s=args.passthrough_sphere_every, max_text_bytes=s.max_message_bytes,
            max_pixels=int(getattr(args, "max_frame_pixels", 0) or 0) or 4096 * 4096)
    from .register import probe_positions
    positions = probe_positions(args.probe_position, names)
    probes = []
    for name, text in named:
        ns = overrides.get(name, args)
        _check_numbers(ns, f"probe {name}: " if name in overrides else "")
        options = SourceOptions(fps=ns.fps, loop=not ns.no_loop, timeout=ns.source_timeout,
                                capture_size=ns.capture_size, fourcc=ns.capture_fourcc,
                                theta_api=ns.theta_api, bracket=ns.bracket,
                                exposure_unit=ns.exposure_unit, query_exposure=bool(ns.camera),
                                max_pixels=ns.max_frame_pixels)
        fixed = [k for k, _ in ns.theta_option if k in _BRACKET_OPTIONS]
        if fixed and ns.bracket:
            raise InputError(f"--theta-option {fixed[0]} and --bracket both set the exposure: "
                             "give one")
        options = dataclasses.replace(options, theta_settings=tuple(ns.theta_option),
                                      theta_check_s=ns.theta_check)
        spec = parse_source(text, options)
        if ns.theta_option and spec.kind != "theta":
            raise InputError(f"--theta-option has no effect on a {spec.kind} source (only "
                             "theta:// reads it): leave it out")
        _check_radiometry(name, spec, ns)
        _file_frame_warnings(name, spec, ns)
        temporal = TemporalSettings(smoothing=ns.smoothing, snap=ns.snap,
                                    change_threshold=ns.change_threshold,
                                    keepalive=ns.keepalive, stale_after=ns.stale_after)
        environment = (EnvironmentSettings(
            32 if ns.environment_size is None else ns.environment_size,
            1.0 if ns.environment_hz is None else ns.environment_hz) if ns.environment else None)
        facing, colour = check_meter_arguments(ns, f"probe {name}: ")
        meter = None
        if ns.lux is not None:
            if not ns.camera:
                raise InputError(f"probe {name}: --lux needs --camera CAMERA.json with an "
                                 "absolute scale (shlight calibrate-response --lux)")
            from ..live.probe.luxmeter import parse_lux_source
            meter = parse_lux_source(ns.lux, ca_file=ns.lux_ca)
            meter.facing, meter.colour = facing, colour
        probes.append(Probe(name, spec, projection=_source_projection(name, spec, ns),
                            engine_options=engine_options(ns), temporal=temporal,
                            backoff_max=ns.reconnect_max, environment=environment,
                            meter=meter))
        from .register import registrar_for
        probes[-1].registrar = registrar_for(ns, name)
        probes[-1].position = positions.get(name)
    publishers = []
    if args.mqtt is not None:       # '' too: refused by the parser, never "no MQTT"
        from ..live.mqtt import MqttPublisher, parse_mqtt_url
        publishers.append(MqttPublisher(parse_mqtt_url(args.mqtt), ca_file=args.mqtt_ca,
                                        backoff_max=args.reconnect_max))
    elif args.mqtt_ca:
        raise InputError("--mqtt-ca needs --mqtt mqtts://...")
    server = ProviderServer(probes, s, publishers)
    if positions or args.room is not None:      # the light at points (docs/probes.md)
        from ..live.probe.points import RoomLight
        server.points.room = RoomLight(probes, args.room, args.lights)
    return server


def _given(words) -> set:
    """The dests that ``--probe-args`` words set themselves (not inherited from the command
    line): argparse leaves an attribute the namespace already has alone, so a namespace
    whose every attribute is a marker shows which ones the words changed."""
    p = _probe_parser()
    # a list each (argparse's append copies a list it finds, then appends: a new object)
    markers = {a.dest: _Unset() for a in p._actions}
    ns = argparse.Namespace(**markers)
    p.parse_args(words, namespace=ns)
    return {k for k, v in vars(ns).items() if v is not markers.get(k)}


class _Unset(list):
    """The value of an option ``--probe-args`` words did not give (see _given)."""


def _check_option_use(args, names, overrides: dict, given: dict) -> None:
    """The rule of :mod:`.options` (an option that does nothing, or contradicts another, is
    refused) across probes: an option of ``--probe-args NAME=...`` is checked in its probe;
    one of the command line in every probe that inherits it, and refused only when it does
    nothing in all of them (``--environment-size 16 --probe-args b=--environment`` is
    fine). ``engine_options`` then skips its own check (``_options_checked``)."""
    from .options import unused_options
    useless, useful = {}, set()     # inherited options: useless in a probe, useful in one
    for name in names:
        ns, own = overrides.get(name, args), given.get(name, set())
        problems = unused_options(ns)
        for dest in own & problems.keys():
            raise InputError(f"--probe-args {name}: {problems[dest]}")
        for dest, line in problems.items():
            useless.setdefault(dest, line)
        useful |= {d for d in vars(ns) if d not in problems and d not in own}
        ns._options_checked = True
    useless = [line for dest, line in useless.items() if dest not in useful]
    if useless:
        raise InputError(useless[0])
    args._options_checked = True


def _file_frame_warnings(name: str, spec, ns) -> None:
    """The first frame's warnings (:func:`.options.frame_warnings`: --camera or --encoding
    on a float frame) for a file source, from its first bytes, at start (other sources show
    their frames later; the projection says its own when the probe builds it)."""
    import stat
    from ..core.radiometry.image_size import EXR_MAGIC
    from ..live.sources import SequenceSource
    from .options import frame_warnings
    if spec.kind == "image":
        path = spec.target
    elif spec.kind == "sequence":
        paths = SequenceSource.expand(spec.target)
        path = paths[0] if paths else None
    else:
        return
    try:
        if path is None or not stat.S_ISREG(os.stat(path).st_mode):   # a FIFO: not now
            return
        with open(path, "rb") as f:
            head = f.read(4)
    except OSError:
        return
    floating = head[:4] == EXR_MAGIC or head[:2] in (b"#?", b"PF", b"Pf")
    for line in frame_warnings(ns, floating):
        logging.getLogger("shlight").warning("probe %s: %s", name, line)


def _source_projection(name: str, spec, ns) -> str:
    """The projection of a probe: for a file source (an image, or a sequence's first file)
    the one ``compute`` reads the same file with (:func:`.options.header_projection`: an
    OpenEXR header's envmap for ``auto``, a contradiction refused, its warnings logged);
    else ``ns.projection``."""
    from ..core.radiometry.images import exr_layout
    from ..live.sources import SequenceSource
    from .options import header_projection
    given = "auto" if getattr(ns, "_auto_projection", False) else ns.projection
    if spec.kind == "image":
        paths = [spec.target]
    elif spec.kind == "sequence":
        paths = SequenceSource.expand(spec.target)[:1]
    else:
        return ns.projection
    try:
        projection, warnings = header_projection(given, [exr_layout(p) for p in paths])
    except InputError as exc:
        raise InputError(f"probe {name}: {exc}") from None
    for line in warnings:
        logging.getLogger("shlight").warning("probe %s: %s", name, line)
    return projection


def _check_radiometry(name: str, spec, ns) -> None:
    """--bracket on a source that cannot set its exposure: refused at start, one line."""
    from ..live.sources.exposure import check_bracket_support
    check_bracket_support(spec.kind, spec.description, ns.bracket, ns.exposure_unit)
    if ns.exposure_unit and spec.kind != "camera":
        raise InputError(f"probe {name}: --exposure-unit is for UVC cameras, not "
                         f"{spec.description}")
    if ns.bracket and not ns.camera:
        logging.getLogger("shlight").warning(
            "probe %s: --bracket without --camera merges with the sRGB curve; calibrate the "
            "camera (shlight calibrate-response) for scene-referred light", name)


def run(args) -> int:
    """Entry point of ``shlight serve``."""
    level = getattr(logging, args.log_level.upper())
    logging.basicConfig(level=level, format="%(asctime)s %(levelname)-7s %(message)s",
                        datefmt="%H:%M:%S")
    logging.getLogger("shlight").setLevel(level)
    from ..live.server.limits import install_repeat_filter
    install_repeat_filter()     # identical warnings: once per 10 s, with a count
    if level > logging.DEBUG:
        logging.getLogger("websockets").setLevel(logging.WARNING)
    from ..live.server.lifecycle import serve_until_stopped
    from .threads import limit_opencv_threads
    limit_opencv_threads(1)     # why: provider/cli/threads.py
    server = build_server(args)
    try:
        asyncio.run(serve_until_stopped(server))
    except KeyboardInterrupt:   # platforms without signal handlers
        pass
    return 0
