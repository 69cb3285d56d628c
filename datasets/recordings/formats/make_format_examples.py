"""Write one small example of every instrument and program format, as its writer writes it.

    python datasets/recordings/formats/make_format_examples.py

The signal is the same damped oscillation in every file (a 1.3 Hz swing from 0.8 rad decaying
at 0.2 1/s, sampled at 50 Hz for 6 s), so each reader's output can be compared with it; the
timegrapher logs hold a decaying amplitude.  The layouts follow the writers named in
docs/recordings.md (phyphox DataExport.java, CASSY Lab 2's files, LabVIEW's .lvm, Logger Pro's
.cmbl, PASCO's CSV, Tracker's data export, an Arduino sketch's Serial.print lines,
TimeGrapher-Net's MeasurementResultLogger, peterhudson/timegrapher's slices.csv).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from escfit.analysis.recordings.labfiles import write_cmbl
from escfit.analysis.recordings.phyphox import write_phyphox_csv
from escfit.analysis.recordings.tg_logs import TGNET_HEADER

HERE = Path(__file__).resolve().parent
T = np.arange(300) / 50.0
THETA = 0.8 * np.exp(-0.2 * T) * np.cos(2 * math.pi * 1.3 * T)
OMEGA = np.gradient(THETA, T)


def main() -> None:
    (HERE / "phyphox_gyroscope.csv").write_text(write_phyphox_csv(
        {"Time (s)": list(T), "Gyroscope x (rad/s)": list(OMEGA), "Gyroscope y (rad/s)": list(0 * OMEGA[:-3]),
         "Gyroscope z (rad/s)": list(0 * OMEGA[:-3])}, separator=";", decimal=","))
    head = ("MIN=0\t-1\r\r\nMAX=6\t1\r\r\nSCALE=6\t1\r\r\nDEC=2\t4\r\r\n"
            'DEF="Zeit" t / s\t"Winkel" &j / \u00b0\r\r\n')
    rows = "".join(f"{t:.2f}\t{math.degrees(a):.4f}\r\r\n".replace(".", ",") for t, a in zip(T, THETA))
    (HERE / "cassy_export.txt").write_bytes(("\ufeff" + head + rows).encode("utf-8"))
    lvm = ("LabVIEW Measurement\t\nWriter_Version\t2\nReader_Version\t2\nSeparator\tTab\nDecimal_Separator\t.\n"
           "Multi_Headings\tNo\nX_Columns\tNo\nTime_Pref\tRelative\nOperator\tescfit\nDate\t2026/01/01\n"
           "Time\t12:00:00.0\n***End_of_Header***\t\n\t\nChannels\t1\t\nSamples\t300\t\nDate\t2026/01/01\t\n"
           "Time\t12:00:00.0\t\nY_Unit_Label\tdeg\t\nX_Dimension\tTime\t\nX0\t0.0000000000000000E+0\t\n"
           "Delta_X\t0.020000\t\n***End_of_Header***\t\t\nX_Value\tAngle\tComment\n")
    (HERE / "labview.lvm").write_text(lvm + "".join(f"\t{math.degrees(a):.6f}\n" for a in THETA))
    (HERE / "loggerpro.cmbl").write_text(write_cmbl({"Run 1": {"Time": ("s", list(T)),
                                                               "Angle": ("\u00b0", list(np.degrees(THETA)))}}))
    (HERE / "pasco.csv").write_text("Time (s) Run #1,Angle (rad) Run #1\n" + "".join(
        f"{t:.2f},{a:.6f}\n" for t, a in zip(T, THETA)))
    x, y = 0.05 + 1.2 * np.sin(THETA), 1.0 - 1.2 * np.cos(THETA)
    (HERE / "tracker_export.txt").write_text("mass A\nt\tx\ty\n" + "".join(
        f"{t:.3f}\t{a:.5f}\t{b:.5f}\n" for t, a, b in zip(T, x, y)))
    (HERE / "arduino_serial.txt").write_text("Encoder ready\n" + "".join(
        f"Time: {round(1000 * t)} ms, Angle: {math.degrees(a):.1f}\n" for t, a in zip(T, THETA)) + "Done.\n")
    lines = ["lift_angle_deg,52.000000", ",".join(TGNET_HEADER)]
    for i in range(40):
        amp = 150.0 + 150.0 * math.exp(-0.05 * i)
        ok = i % 13 != 5
        lines.append(",".join(["1", "0", str(i + 1), f"{2.0 + 0.4 * i:.6f}", "18000", "DialUp", "true",
                               f"{-2.5 + 0.02 * i:.6f}", str(ok).lower(), f"{amp:.6f}" if ok else "", "true", "0.300000",
                               "false", "", "false", "", "true", "200.000000", str(i), "-2.400000", "0.300000", str(i),
                               "260.000000", "30.000000", "0", "0"]))
    (HERE / "timegrapher_net.csv").write_text("\n".join(lines) + "\n1,0,41,18.400000,18000,Dial")
    start = np.arange(0.0, 6 * 3600.0, 600.0)
    (HERE / "timegrapher_slices.csv").write_text("start_s,end_s,rate_s_per_day,beat_error_ms,amplitude_deg\n" + "".join(
        f"{s:.2f},{s + 600:.2f},{6.0 - 4e-4 * s:.2f},0.250,{300 - 3e-3 * s:.1f}\n" for s in start))


if __name__ == "__main__":
    main()
