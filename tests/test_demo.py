"""The demo voyage runs end to end on a reduced grid and says what seed 000 says."""

import re

from optroute.cli import main


def test_demo_runs_end_to_end_and_writes_figures(tmp_path, capsys):
    code = main(["demo", "--out", str(tmp_path / "demo"), "--cell-nm", "120"])
    out = capsys.readouterr().out
    assert code == 0
    gc = re.search(r"great circle, forced slow-downs\s+([\d,]+)\s+(\d+) d\s+(\d+) h", out)
    opt = re.search(r"optimised route\s+([\d,]+)\s+(\d+) d\s+(\d+) h", out)
    assert gc and opt
    gc_h = int(gc.group(2)) * 24 + int(gc.group(3))
    opt_h = int(opt.group(2)) * 24 + int(opt.group(3))
    # EP 2145155: the great circle takes more than 12 days, the routed ship about 8 d 8 h
    assert gc_h > 12 * 24 and opt_h < 8.5 * 24
    pngs = sorted((tmp_path / "demo").glob("*.png"))
    assert [p.name for p in pngs] == ["profile_great_circle.png", "profile_optimised.png", "route_map.png"]
    assert all(p.stat().st_size > 20_000 for p in pngs)


def test_demo_help():
    assert main(["demo", "--help"]) == 0
