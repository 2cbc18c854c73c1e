"""Real part programs run as a CNC runs them (issue 15): the corpus to arrival, corner modes,
rapids that cut nothing, and the program's end."""

import pathlib

import pytest

import contour_gym.paths as cgp
from contour_gym import simulate

DATA = pathlib.Path(__file__).parent / "data" / "gcode"
XY, XYZ = "xy_servo_coulomb", "xyz_pmlsm"
# every program on a machine with matching axes: 3-axis programs also on the X-Y machine (their
# Z-only moves are non-cutting), except the one with arcs in the XZ and YZ planes
MACHINES = {"linuxcnc_pocket.ngc": (XY, XYZ), "grbl_engrave.gcode": (XY, XYZ),
            "cam_bracket.nc": (XY, XYZ), "fanuc_plate.nc": (XY, XYZ), "part_2d.ngc": (XY, XYZ),
            "arcs_3axis.ngc": (XYZ,)}


@pytest.mark.parametrize(
    ("name", "plant"), [(n, p) for n, plants in sorted(MACHINES.items()) for p in plants]
)
def test_every_corpus_program_runs_to_arrival(name, plant):
    path = cgp.from_gcode((DATA / name).read_text())
    m = simulate(plant=plant, path=path)
    assert m["finished"] == 1.0, (name, plant)
    # at the level of the machine's own errors: a lost foot point would report mm
    assert 0.0 < m["max_contour_error"] < 100e-6, m["max_contour_error"]


def test_the_corpus_table_covers_every_file():
    assert sorted(p.name for p in DATA.iterdir()) == sorted(MACHINES)


SQUARE = "G1 X20 F{f}\nG1 Y20\nG1 X0\nG1 Y0\n"


def _square(mode, feed=3000):
    return cgp.from_gcode(f"G21 G90 G17 {mode}\nG0 X0 Y0\n" + SQUARE.format(f=feed) + "M30\n")


def test_exact_stop_is_slower_and_more_accurate_than_blending():
    runs = {mode: simulate(plant=XY, path=_square(mode)) for mode in
            ("G61", "G64 P0.01", "G64 P0.05")}
    cycle = [runs[k]["cycle_time"] for k in ("G61", "G64 P0.01", "G64 P0.05")]
    peak = [runs[k]["max_contour_error"] for k in ("G61", "G64 P0.01", "G64 P0.05")]
    assert cycle[0] > cycle[1] > cycle[2], cycle
    assert peak[0] < peak[1] < peak[2], peak
    # blending keeps the corner within about its tolerance P (mm): the servo adds its lag
    assert peak[2] < 0.05e-3 and peak[1] < 0.02e-3


CUTS = "G1 X20 F1500\nG1 Y10\nG1 X0\nG1 Y0\n{between}G1 X50 F1500\nG1 Y10\nG1 X30\nG1 Y0\n"


def test_rapids_do_not_change_the_contour_metrics():
    # 000's machine: on 004's, Coulomb friction holds each stop anywhere in its band, so the
    # state a cut starts from depends on the whole history (its sub-um mean error moves 2x)
    def run(between):
        text = "G21 G90 G17 G61\nG0 X0 Y0\n" + CUTS.format(between=between) + "M30\n"
        return simulate(plant="xy_dc_servo", path=cgp.from_gcode(text))

    # the same last approach, once straight and once after 300 mm of rapids that cut nothing
    direct = run("G0 X30 Y-5\nG0 Y0\n")
    detour = run("G0 X90 Y90\nG0 X-40 Y60\nG0 X30 Y-5\nG0 Y0\n")
    assert detour["cycle_time"] > direct["cycle_time"] + 1.0  # everything counts in the time
    for key in ("max_contour_error", "mean_contour_error", "rms_contour_error", "cea"):
        assert detour[key] == pytest.approx(direct[key], rel=0.05), key


def test_words_after_the_program_end_do_not_run():
    plain = simulate(plant=XY, path=_square("G61"))
    text = "G21 G90 G17 G61\nG0 X0 Y0\n" + SQUARE.format(f=3000) + "M30\nG1 X90 Y90\nG0 X0\n"
    ended = simulate(plant=XY, path=cgp.from_gcode(text))
    assert ended["cycle_time"] == plain["cycle_time"]
    assert ended["max_contour_error"] == plain["max_contour_error"]
