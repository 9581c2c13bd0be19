"""vibrissa sweep's terminal output without DDS: the node's log lines go above the progress bar."""

import io

from tqdm import tqdm

from vibrissa_ros.ros.sweep import SWEEP_COLUMNS, SweepRow, _forward, write_sweep_csv


def test_node_log_lines_are_printed_above_the_bar_never_into_it():
    out = io.StringIO()
    bar = tqdm(total=1600, unit="pose", file=out, desc="sweep", mininterval=0)
    bar.update(200)
    log = io.StringIO("[INFO] [1.0] [whisker_node]: ready\n[WARN] [2.0] [whisker_node]: dropped\n")
    _forward(log, out)
    bar.update(200)
    bar.close()
    text = out.getvalue()
    for line in ("[INFO] [1.0] [whisker_node]: ready", "[WARN] [2.0] [whisker_node]: dropped"):
        i = text.index(line)
        assert text[i - 1] in "\r\n", repr(text[max(0, i - 40):i + 10])  # starts its own line
        assert text[i + len(line)] == "\n"
    assert "poses[" not in text and "pose[" not in text
    assert "400/1600" in text


def test_sweep_csv_writes_empty_fields_for_no_contact():
    out = io.StringIO()
    write_sweep_csv([SweepRow(0.1, 0.0, 1.5, 0, 0.0, 0.0, 0.0, 0.0, None, None, None),
                     SweepRow(0.0, 0.0, 1.5, 2, 0.1, -0.2, 3e-3, 0.25, 0.01, 0.05, 0.1)], out)
    lines = out.getvalue().splitlines()
    assert lines[0] == ",".join(SWEEP_COLUMNS)
    assert lines[1].endswith(",0.0,,,") and lines[2].endswith(",0.25,0.01,0.05,0.1")
