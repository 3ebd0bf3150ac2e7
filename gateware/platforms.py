"""Build targets: the ULX3S boards, and a plain ECP5 device with a pin map.

Both get the same logical resources for the RTS sample interface
(:func:`rts_resources`): ``rts_adc`` (``data`` 16 pins DDR in, ``clk`` out)
and ``rts_dac`` (``data`` 16 pins DDR out, ``clk`` out, ``iq`` out).
"""

import json
from pathlib import Path

from amaranth.build import Resource, Subsignal, Pins, Attrs, Clock
from amaranth.vendor import LatticeECP5Platform

__all__ = ["BOARDS", "ULX3S_RTS_PINS", "rts_resources", "make_platform", "pin_table"]

#: ULX3S GPIO header pins (Amaranth connector ``gpio 0``: ``N+`` is GPn, ``N-`` is GNn).
ULX3S_RTS_PINS = {
    "adc_data": "0+ 0- 1+ 1- 2+ 2- 3+ 3- 4+ 4- 5+ 5- 6+ 6- 7+ 7-".split(),   # bit 0 first
    "adc_clk": "8+",
    "dac_data": "14+ 14- 15+ 15- 16+ 16- 17+ 17- 18+ 18- 19+ 19- 20+ 20- 21+ 21-".split(),
    "dac_clk": "22+",
    "dac_iq": "22-",
    "acp": "23+",
    "arp": "23-",
}

#: The default pin map of the plain-device target: the ULX3S's balls (caBGA381).
DEFAULT_PINMAP = {
    "clk": "G2", "clk_mhz": 25.0, "uart_rx": "M1", "uart_tx": "L4", "io_type": "LVCMOS33",
    "leds": ["B2", "C2"],
}


def _ulx3s_ball(conn_pin):
    from amaranth_boards.ulx3s import ULX3S_85F_Platform
    for c in ULX3S_85F_Platform.connectors:
        if c.name == "gpio" and c.number == 0:
            return c.mapping[conn_pin]
    raise KeyError(conn_pin)


def pin_table():
    """Rows ``(signal, header pin, ball)`` of the ULX3S RTS pin map."""
    rows = []
    for name in ("adc_data", "adc_clk", "dac_data", "dac_clk", "dac_iq", "acp", "arp"):
        pins = ULX3S_RTS_PINS[name]
        if isinstance(pins, list):
            for k, p in enumerate(pins):
                rows.append((f"{name}[{k}]", ("GP" if p.endswith("+") else "GN") + p[:-1], _ulx3s_ball(p)))
        else:
            rows.append((name, ("GP" if pins.endswith("+") else "GN") + pins[:-1], _ulx3s_ball(pins)))
    return rows


def rts_resources(pins=ULX3S_RTS_PINS, conn=("gpio", 0), io_type="LVCMOS33"):
    """The ``rts_adc`` and ``rts_dac`` resources over ``pins`` (connector pins when
    ``conn`` is given, balls when it is ``None``), and ``rts_scan`` (the
    radar's ``acp`` and ``arp`` inputs) where ``pins`` names them."""
    a = Attrs(IO_TYPE=io_type)
    drive = Attrs(IO_TYPE=io_type, SLEWRATE="FAST", DRIVE="8")
    scan = [Resource("rts_scan", 0, Subsignal("acp", Pins(pins["acp"], dir="i", conn=conn), a),
                     Subsignal("arp", Pins(pins["arp"], dir="i", conn=conn), a))] if "acp" in pins else []
    return scan + [
        Resource("rts_adc", 0,
                 Subsignal("data", Pins(" ".join(pins["adc_data"]), dir="i", conn=conn), a),
                 Subsignal("clk", Pins(pins["adc_clk"], dir="o", conn=conn), drive)),
        Resource("rts_dac", 0,
                 Subsignal("data", Pins(" ".join(pins["dac_data"]), dir="o", conn=conn), drive),
                 Subsignal("clk", Pins(pins["dac_clk"], dir="o", conn=conn), drive),
                 Subsignal("iq", Pins(pins["dac_iq"], dir="o", conn=conn), drive)),
    ]


def _esp32_gpio0_ball(plat):
    """The ball of the ULX3S's ESP32 GPIO0 (amaranth-boards' ``esp32`` resource), or None."""
    for (name, number), res in plat.resources.items():
        if name == "esp32" and number == 0:
            for sub in res.ios:
                if getattr(sub, "name", None) == "gpio0":
                    return sub.ios[0].names[0]
    return None


def _ulx3s(cls_name):
    def make():
        import amaranth_boards.ulx3s as u
        plat = getattr(u, cls_name)()
        plat.add_resources(rts_resources())
        # ESP32 GPIO0 alone (litex-boards' name): an SDRAM build drives it high
        # so that the ESP32 stays off the FPGA's reset, as litex-boards does.
        ball = _esp32_gpio0_ball(plat)
        if ball is not None:
            plat.add_resources([Resource("wifi_gpio0", 0, Pins(ball, dir="o"), Attrs(IO_TYPE="LVCMOS33"))])
        return plat
    return make


BOARDS = {
    "ulx3s-12f": _ulx3s("ULX3S_12F_Platform"),
    "ulx3s-25f": _ulx3s("ULX3S_25F_Platform"),
    "ulx3s-45f": _ulx3s("ULX3S_45F_Platform"),
    "ulx3s-85f": _ulx3s("ULX3S_85F_Platform"),
}


def _default_ball_pinmap():
    pm = dict(DEFAULT_PINMAP)
    for name, pins in ULX3S_RTS_PINS.items():
        pm[name] = [_ulx3s_ball(p) for p in pins] if isinstance(pins, list) else _ulx3s_ball(pins)
    return pm


def make_platform(board="ulx3s-85f", *, device=None, package=None, speed=None, pinmap=None):
    """A platform instance for ``board``, or for a plain ECP5 ``device`` (``board=None``).

    For a plain device, ``pinmap`` (a JSON file or dict) names the balls of
    ``clk`` (with ``clk_mhz``), ``uart_rx``, ``uart_tx``, ``adc_data`` (16),
    ``adc_clk``, ``dac_data`` (16), ``dac_clk``, ``dac_iq`` and optionally
    ``acp`` and ``arp`` (a build with the antenna scan needs both), ``leds``
    and ``io_type``; without it the ULX3S balls are used (caBGA381).
    """
    if board is not None:
        if board not in BOARDS:
            raise ValueError(f"Board must be one of {', '.join(BOARDS)}, not {board!r}")
        return BOARDS[board]()
    if device not in LatticeECP5Platform._nextpnr_device_options:
        raise ValueError(f"ECP5 device must be one of "
                         f"{', '.join(LatticeECP5Platform._nextpnr_device_options)}, not {device!r}")
    if package not in LatticeECP5Platform._nextpnr_package_options:
        raise ValueError(f"ECP5 package must be one of "
                         f"{', '.join(LatticeECP5Platform._nextpnr_package_options)}, not {package!r}")
    if str(speed) not in ("6", "7", "8"):
        raise ValueError(f"ECP5 speed grade must be 6, 7 or 8, not {speed!r}")
    if pinmap is None:
        if package != "BG381":
            raise ValueError(f"Package {package} needs a pin map (--pinmap FILE.json); the built-in "
                             f"one is the ULX3S's, for BG381")
        pm = _default_ball_pinmap()
    elif isinstance(pinmap, dict):
        pm = dict(pinmap)
    else:
        try:
            pm = json.loads(Path(pinmap).read_text(encoding="utf-8"))
        except OSError as error:
            raise ValueError(f"Cannot read the pin map {pinmap}: {error.strerror or error}") from None
        except (UnicodeDecodeError, json.JSONDecodeError) as error:
            raise ValueError(f"The pin map {pinmap} is not valid JSON: {error}") from None
    where = "Pin map" if isinstance(pinmap, dict) else f"Pin map {pinmap}"
    if not isinstance(pm, dict):
        raise ValueError(f"{where} must be a JSON object of signal names to balls")
    missing = [k for k in ("clk", "clk_mhz", "uart_rx", "uart_tx", "adc_data", "adc_clk",
                           "dac_data", "dac_clk", "dac_iq") if k not in pm]
    if missing:
        raise ValueError(f"{where} lacks {', '.join(missing)}")
    for k in ("adc_data", "dac_data"):
        if not (isinstance(pm[k], list) and len(pm[k]) == 16 and all(isinstance(b, str) for b in pm[k])):
            raise ValueError(f"{where}: entry {k} must list 16 balls, not {pm[k]!r}")
    if ("acp" in pm) != ("arp" in pm):
        raise ValueError(f"{where}: entries acp and arp go together")
    for k in ("clk", "uart_rx", "uart_tx", "adc_clk", "dac_clk", "dac_iq", "acp", "arp", "io_type"):
        if k in pm and not isinstance(pm[k], str):
            raise ValueError(f"{where}: entry {k} must be a ball name, not {pm[k]!r}")
    if not isinstance(pm.get("leds", []), list) or not all(isinstance(b, str) for b in pm.get("leds", [])):
        raise ValueError(f"{where}: entry leds must list balls, not {pm['leds']!r}")
    clk_mhz = pm["clk_mhz"]
    if not (isinstance(clk_mhz, (int, float)) and not isinstance(clk_mhz, bool) and 0 < clk_mhz < 1000):
        raise ValueError(f"{where}: clk_mhz must be the board clock in MHz, not {clk_mhz!r}")
    io_type = pm.get("io_type", "LVCMOS33")
    a = Attrs(IO_TYPE=io_type)
    resources = [
        Resource("clk", 0, Pins(pm["clk"], dir="i"), Clock(float(pm["clk_mhz"]) * 1e6), a),
        Resource("uart", 0, Subsignal("rx", Pins(pm["uart_rx"], dir="i")),
                 Subsignal("tx", Pins(pm["uart_tx"], dir="o")), a),
        *rts_resources(pm, conn=None, io_type=io_type),
    ]
    for k, ball in enumerate(pm.get("leds", [])):
        resources.append(Resource("led", k, Pins(ball, dir="o"), a))
    attrs = dict(device=device, package=package, speed=str(speed), default_clk="clk",
                 resources=resources, connectors=[])
    cls = type("PlainECP5Platform", (LatticeECP5Platform,), attrs)
    return cls()
