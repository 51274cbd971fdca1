"""What moli knows of each DaISy file: its folder, shape, channels, period and checksum."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["DaisySpec"]

DESTILL_NOISE_LEVELS = (0, 10, 20, 30)
DISTILL2_STEPS = (1, 2, 3)


@dataclass(frozen=True)
class DaisySpec:
    folder: str
    description: str
    shape: tuple[int, int]  # rows and columns of the file
    u_cols: tuple[int, ...]  # 0-based; for destill the noise-free block
    y_cols: tuple[int, ...]
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    Ts: float | None  # None: not stated by DaISy
    Ts_unit: str = "s"
    sha256: str | None = None


def _span(start: int, stop: int) -> tuple[int, ...]:
    return tuple(range(start, stop))


_PI, _ME, _TH = "process_industry", "mechanical", "thermic"

SPECS: dict[str, DaisySpec] = {
    "ballbeam": DaisySpec(
        _ME, "ball and beam: beam angle to ball position", (1000, 2), (0,), (1,),
        ("beam angle",), ("ball position",), 0.1,
        sha256="e9c48a4f7474953969d4950b4ef72558084b1995f776792ac0cbc80550e6ff42"),
    "CD_player_arm": DaisySpec(
        _ME, "CD-player arm, closed-loop data converted to open loop", (2048, 4), (0, 1), (2, 3),
        ("force 1", "force 2"), ("tracking 1", "tracking 2"), None,
        sha256="a2ef4bf51c3102487a0690c7a68d97f3b1966cd07319580011a97fc0af904eaa"),
    "cstr": DaisySpec(
        _PI, "continuous stirred tank reactor (simulated)", (7500, 4), (1,), (2, 3),
        ("coolant flow q",), ("concentration Ca", "temperature T"), 0.1, "min",
        sha256="0ffdda8a1b962d377dc34371be105bd9dcaef7fcca40554e666841efeec6b84d"),
    "destill": DaisySpec(
        _PI, "ethane-ethylene distillation column (simulated), 4 noise levels", (90, 33),
        _span(1, 6), _span(21, 24),
        ("reboiler duty/feed", "reflux/feed", "distillate/feed", "feed ethane", "top pressure"),
        ("top ethane", "bottom ethylene", "differential pressure"), 15.0, "min",
        sha256="cb2fe8d4cc6c461c443f03974e97f76a3145559c0099b2319f523d374747057d"),
    "distill2": DaisySpec(
        _PI, "fractional distillation column (simulated), step responses", (251, 7),
        (), _span(1, 7),
        ("cooling temperature", "reboiling temperature", "pressure"),
        ("top product flow", "C4 concentration"), 10.0,
        sha256="837cc6243c0b20080a89a6207c5fb14928ac5cfa922b73a02c4bbab2a3fd5346"),
    "dryer": DaisySpec(
        _ME, "laboratory hair dryer: heater voltage to outlet air temperature", (1000, 2),
        (0,), (1,), ("heater voltage",), ("outlet temperature",), None,
        sha256="adcb2f5a1d9e174d08dd49f7f037626745b5e69cbda0bc1e8dca2a7c687d4538"),
    "dryer2": DaisySpec(
        _PI, "industrial dryer (Cambridge Control)", (867, 7), (1, 2, 3), (4, 5, 6),
        ("fuel flow", "exhaust fan speed", "raw material flow"),
        ("dry bulb temperature", "wet bulb temperature", "moisture content"), 10.0,
        sha256="0b3a3d6341212c9919a60a8ac06c1bd6069f055f4d72bc27da767f66a47cafc1"),
    "evaporator": DaisySpec(
        _PI, "industrial four-stage evaporator", (6305, 6), (0, 1, 2), (3, 4, 5),
        ("feed flow", "vapour flow", "cooling water flow"),
        ("dry matter content", "product flow", "product temperature"), None,
        sha256="3a74c747140602e44b9d099c73170656ac56d43d9241cf85ff84822f2d230f13"),
    "exchanger": DaisySpec(
        _PI, "liquid-saturated steam heat exchanger", (4000, 3), (1,), (2,),
        ("liquid flow q",), ("outlet temperature",), 1.0,
        sha256="cfb5a447fb573f87de33760e156cbf5da1f9802ae8a03a1b3c39ce8eb656fa6c"),
    "flutter": DaisySpec(
        _ME, "wing flutter (details confidential)", (1024, 2), (0,), (1,),
        ("u",), ("y",), None,
        sha256="e944d4bc32ac403bc20f64e45afff525456dd19166962ebcc47a2cc9f9b39d81"),
    "glassfurnace": DaisySpec(
        _PI, "glass furnace (Philips), six temperatures in one cross section", (1247, 10),
        (1, 2, 3), _span(4, 10), ("heating 1", "cooling", "heating 2"),
        tuple(f"temperature {i}" for i in range(1, 7)), None,
        sha256="073cc118b7aaf589da46b8472be1767ed5240186a4d00df36bc389326a3f8f35"),
    "heating_system": DaisySpec(
        _TH, "lamp-heated steel plate", (801, 3), (1,), (2,),
        ("lamp voltage",), ("plate temperature",), 2.0,
        sha256="3bfbe8424719830870b153067eeff40ebff3afb0204c150ed7103b5d6c1908bc"),
    "pHdata": DaisySpec(
        _PI, "pH neutralisation in a stirred tank (simulated)", (2001, 4), (1, 2), (3,),
        ("acid flow", "base flow"), ("pH",), 10.0,
        sha256="9b84a2c8b8ec614803f9d75dec7e4eaaa933d45c645d24794bb11ce185f0e7e4"),
    "robot_arm": DaisySpec(
        _ME, "flexible robot arm: reaction torque to arm acceleration", (1024, 2), (0,), (1,),
        ("reaction torque",), ("arm acceleration",), None,
        sha256="4ee167a8a28ce0da868d1b42f6a2fe0c456ea0e56b60c70915bf6d4a2a933635"),
    "thermic_res_wall": DaisySpec(
        _TH, "heat flow through a two-layer wall", (1680, 3), (0, 1), (2,),
        ("internal temperature", "external temperature"), ("heat flow density",), None,
        sha256="b9fb76c775ede37958a71d1c584410fc4352e5ac64ca541e0cc926797e1ab7c1"),
    # The next three have no published checksum: their shape is checked instead.
    "steamgen": DaisySpec(
        _PI, "steam generator model, Abbott Power Plant", (9600, 9), _span(1, 5), _span(5, 9),
        ("fuel", "air", "level reference", "load disturbance"),
        ("drum pressure", "excess oxygen", "drum water level", "steam flow"), 3.0),
    "winding": DaisySpec(
        _PI, "web winding test setup", (2500, 7), _span(0, 5), (5, 6),
        ("speed S1", "speed S2", "speed S3", "current I1*", "current I3*"),
        ("tension T1", "tension T3"), 0.1),
    # Columns 9-11 ("Yr") are not explained by DaISy and are not returned.
    "powerplant": DaisySpec(
        _PI, "120 MW power plant, Pont-sur-Sambre", (200, 12), _span(1, 6), _span(6, 9),
        ("gas flow", "turbine valves", "spray flow", "gas dampers", "air flow"),
        ("steam pressure", "main steam temperature", "reheat steam temperature"), 1228.8),
}
