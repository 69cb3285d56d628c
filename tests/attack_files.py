"""Hostile packed files for the attack table: small on disk, huge or damaged once unpacked.

Each builder writes its file in a few milliseconds, however much it declares: a deflate stream
of one repeated chunk is built from a single compressed copy of the chunk (flushed so that every
copy compresses to the same bytes), and the zip's headers are written by hand.  The rows at the
bottom join :data:`tests.test_attack_table.ATTACKS`; each must end in exit 2, one line, nothing
written, within the table's memory ceiling.
"""

from __future__ import annotations

import struct
import zlib

import numpy as np

from .conftest import DATASETS

TS = DATASETS / "recordings" / "monday_timeseries.csv"


def angles() -> list[str]:
    """The shipped sampled decay's angle readings (deg), as text."""
    return [line.split(",")[1].strip() for line in TS.read_text().splitlines() if line[:1].isdigit()]


def repeated_deflate(head: bytes, chunk: bytes, copies: int, tail: bytes) -> bytes:
    """A raw deflate stream of ``head + chunk * copies + tail``, built in O(len(chunk)) time."""
    c = zlib.compressobj(9, zlib.DEFLATED, -15)
    first = c.compress(head) + c.flush(zlib.Z_FULL_FLUSH)
    one = c.compress(chunk) + c.flush(zlib.Z_FULL_FLUSH)  # a full flush forgets the history: copies are alike
    return first + one * copies + c.compress(tail) + c.flush()


def zip_bytes(members: list[tuple[str, bytes, int, int]], *, method: int = 8, flags: int = 0) -> bytes:
    """A zip of ``(name, deflated bytes, unpacked size, crc)`` members, headers written by hand."""
    out, central = b"", b""
    for name, data, size, crc in members:
        raw_name = name.encode()
        offset = len(out)
        out += struct.pack("<IHHHHHIIIHH", 0x04034B50, 20, flags, method, 0, 0, crc, len(data), size,
                           len(raw_name), 0) + raw_name + data
        central += struct.pack("<IHHHHHHIIIHHHHHII", 0x02014B50, 20, 20, flags, method, 0, 0, crc, len(data), size,
                               len(raw_name), 0, 0, 0, 0, 0, offset) + raw_name
    end = struct.pack("<IHHHHIIH", 0x06054B50, 0, 0, len(members), len(members), len(central), len(out), 0)
    return out + central + end


def member(name: str, text: bytes) -> tuple[str, bytes, int, int]:
    return name, repeated_deflate(text, b"", 0, b""), len(text), zlib.crc32(text)


def labx_text(n: int = 400) -> bytes:
    """A small CASSY .labx (time and angle channels) of the shipped decay."""
    def channel(quantity, unit, values):
        cells = "".join(f"<value>{v}</value>" for v in values)
        return (f"<channels><channel><quantity>{quantity}</quantity><symbol>x</symbol><unit>{unit}</unit>"
                f'<values count="{len(values)}">{cells}</values></channel></channels>')
    a = angles()[:n]
    body = channel("Zeit", "s", [f"{i / 400:.4f}" for i in range(len(a))]) + channel("Winkel", "°", a)
    return f'<?xml version="1.0" encoding="utf-8"?><cassylab><allchannels>{body}</allchannels></cassylab>'.encode()


def labx_expanding(w) -> None:
    """A compressed .labx of some 1 MB whose data.xml unpacks to 1.0 GB (just under 1 GiB)."""
    head = b'<?xml version="1.0"?><cassylab><allchannels><channels><channel><unit>s</unit><values>'
    chunk = b"<value>1.25</value>" * 52_632  # 1 MB
    copies = 1000
    tail = b"</values></channel></channels></allchannels></cassylab>"
    size = len(head) + len(chunk) * copies + len(tail)
    (w / "d.labx").write_bytes(zip_bytes([("data.xml", repeated_deflate(head, chunk, copies, tail), size, 0)]))


def labx_damaged(how: str):
    def setup(w) -> None:
        name, data, size, crc = member("data.xml", labx_text())
        if how == "crc":
            blob = zip_bytes([(name, data, size, crc ^ 0xFFFF)])
        elif how == "method":
            blob = zip_bytes([(name, data, size, crc)], method=99)
        else:
            blob = zip_bytes([(name, data, size, crc)], flags=0x1)
        (w / "d.labx").write_bytes(blob)
    return setup


def phyphox_many_sets(w) -> None:
    """A phyphox zip of 20 kB: a recording too short to fit (refused once read) and ten sets of
    190 MB each that nobody asked for."""
    rows = "".join(f"{i / 400:.9E},{float(a):.9E}\n" for i, a in enumerate(angles()[:5]))
    raw = f'"Time (s)","Angle (deg)"\n{rows}'.encode()
    head = b'"Time (s)","X (m/s^2)"\n'
    chunk = b"1.000000000E0,2.000000000E0\n" * 37_450  # 1 MB
    big = repeated_deflate(head, chunk, 190, b"")
    crc = zlib.crc32(head)
    for _ in range(190):
        crc = zlib.crc32(chunk, crc)
    members = [member("Raw Data.csv", raw)]
    members += [(f"Set {k}.csv", big, len(head) + len(chunk) * 190, crc) for k in range(10)]
    (w / "p.zip").write_bytes(zip_bytes(members))


def mat73_declaring(kind: str):
    """A v7.3 .mat of a few kB with the decay as ``theta`` and ``t`` beside a variable that
    declares 2e9 doubles and holds none of them; or ``t`` beside a text declaring 1.7e8
    characters (no angle: refused once the numbers are read)."""
    def setup(w) -> None:
        import h5py

        a = np.radians(np.array(angles(), dtype=float))
        with h5py.File(w / "m.mat", "w", userblock_size=512) as f:
            if kind != "char":
                f["theta"] = a[None, :]
                f["theta"].attrs["MATLAB_class"] = np.bytes_("double")
            f["t"] = (np.arange(a.size) / 400.0)[None, :]
            f["t"].attrs["MATLAB_class"] = np.bytes_("double")
            if kind == "char":
                big = f.create_dataset("notes", shape=(170_000_000, 1), dtype="uint16", chunks=(1 << 16, 1))
                big.attrs["MATLAB_class"] = np.bytes_("char")
            else:
                big = f.create_dataset("unused", shape=(2_000_000_000, 1), dtype="float64", chunks=(1 << 16, 1))
                big.attrs["MATLAB_class"] = np.bytes_("double")
        with open(w / "m.mat", "r+b") as fh:
            fh.write(b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Jan  1 00:00:00 2024 HDF5 schema 1.00 .")
    return setup


def mat5_compressed_expanding(w) -> None:
    """A compressed v5 .mat of 1 MB whose one variable unpacks to 1.16 GB of doubles."""
    n = 145_000_000
    name = b"big\x00\x00\x00\x00\x00"
    matrix = (struct.pack("<II", 6, 8) + struct.pack("<II", 6, 0)         # array flags: double
              + struct.pack("<II", 5, 8) + struct.pack("<ii", n, 1)       # dimensions n x 1
              + struct.pack("<II", 1, 3) + name                           # name 'big'
              + struct.pack("<II", 9, n * 8))                             # the doubles follow
    body_size = len(matrix) + n * 8
    head = struct.pack("<II", 14, body_size) + matrix
    chunk = bytes(1 << 20)
    zdata = zlib.compressobj(9, zlib.DEFLATED, 15)
    stream = zdata.compress(head) + zdata.flush(zlib.Z_FULL_FLUSH)
    one = zdata.compress(chunk) + zdata.flush(zlib.Z_FULL_FLUSH)
    copies, rest = divmod(n * 8, len(chunk))
    stream += one * copies + zdata.compress(bytes(rest)) + zdata.flush()
    header = b"MATLAB 5.0 MAT-file, written by a test".ljust(116, b" ") + bytes(8) + struct.pack("<H", 0x0100) + b"IM"
    (w / "m.mat").write_bytes(header + struct.pack("<II", 15, len(stream)) + stream)


def text_file(name: str, text: str):
    def setup(w) -> None:
        (w / name).write_text(text)
    return setup


def lvm_with_interval(dx: str):
    """A LabVIEW .lvm of the decay whose header declares the sampling interval ``dx`` (s)."""
    head = ("LabVIEW Measurement\t\nWriter_Version\t2\nReader_Version\t2\nSeparator\tTab\nDecimal_Separator\t.\n"
            "Multi_Headings\tYes\nX_Columns\tNo\nTime_Pref\tRelative\n***End_of_Header***\t\n\t\nChannels\t1\t\n"
            f"Samples\t{len(angles())}\t\nY_Unit_Label\tDeg\t\nX_Dimension\tTime\t\nX0\t0.0\t\nDelta_X\t{dx}\t\n"
            "***End_of_Header***\t\t\nX_Value\tAngle\tComment\n")
    return text_file("d.lvm", head + "".join(f"\t{a}\n" for a in angles()))


def spaced(dt: float) -> str:
    return "time_s,theta_deg\n" + "".join(f"{i * dt!r},{a}\n" for i, a in enumerate(angles()))


def decimal_comma_times() -> str:
    return "time,angle\n" + "".join(f"{i / 400:.4f}".replace(".", ",") + f",{a}\n" for i, a in enumerate(angles()))


def scene_effect(table: str):
    return text_file("e.toml", 'model = "balance"\nswitching = "angle"\n[oscillator]\nomega0 = 15.0\ntheta0 = 1.0\n'
                     f"[run]\nswings = 10\n{table}\n")


def rig_long_header(w) -> None:
    text = (w / "data.csv").read_text()
    (w / "data.csv").write_text(text.replace("load_g,dw_g,speed_ft_s,material",
                                             'load_g,dw_g,speed_ft_s,"' + "m" * 140_000 + '"', 1))


def newline_in_name(w) -> None:
    (w / "a\nswitching = 1\n#.csv").write_text((w / "data.csv").read_text().replace("0.0723", "x.0723"))


FIT_TS = ["--scene", "ts.toml", "--out", "r.h5"]

# (class, setup of the folder, command, fragments of the one stderr line)
HOSTILE_FILES = [
    ("labx-compressed-expanding-to-1gb", labx_expanding, ["fit", "d.labx", *FIT_TS], ["d.labx", "data.xml", "MB"]),
    ("labx-member-bad-crc", labx_damaged("crc"), ["fit", "d.labx", *FIT_TS], ["d.labx", "data.xml", "damaged"]),
    ("labx-member-unknown-method", labx_damaged("method"), ["fit", "d.labx", *FIT_TS], ["d.labx", "data.xml"]),
    ("labx-member-encrypted", labx_damaged("encrypted"), ["fit", "d.labx", *FIT_TS], ["d.labx", "encrypted"]),
    ("phyphox-zip-of-unneeded-sets", phyphox_many_sets, ["fit", "p.zip", *FIT_TS], ["p.zip"]),
    ("mat73-declaring-2e9-doubles", mat73_declaring("double"), ["fit", "m.mat", *FIT_TS], ["m.mat", "unused"]),
    ("mat73-declaring-a-huge-text", mat73_declaring("char"), ["fit", "m.mat", *FIT_TS], ["m.mat"]),
    ("mat5-compressed-expanding", mat5_compressed_expanding, ["fit", "m.mat", *FIT_TS], ["m.mat", "big", "MB"]),
    ("unquoted-decimal-comma-times", text_file("d.csv", decimal_comma_times()), ["fit", "d.csv", *FIT_TS],
     ["d.csv:1", "decimal comma"]),
    ("unquoted-decimal-comma-times-init", text_file("d.csv", decimal_comma_times()), ["init", "d.csv"],
     ["d.csv:1", "decimal comma"]),
    ("samples-1e-300-s-apart", text_file("d.csv", spaced(1e-300)), ["fit", "d.csv", *FIT_TS], ["d.csv", "1e-300 s"]),
    ("samples-1e300-s-apart", text_file("d.csv", spaced(1e300)), ["fit", "d.csv", *FIT_TS], ["d.csv", "1e+300 s"]),
    ("lvm-delta-x-1e-300", lvm_with_interval("1E-300"), ["fit", "d.lvm", *FIT_TS], ["d.lvm", "1e-300 s"]),
    ("sample-rate-1e-250-hz", text_file("a.csv", "theta_deg\n" + "\n".join(angles()) + "\n"),
     ["fit", "a.csv", "--format", "raw", "--sample-rate", "1e-250 Hz", "--angle-unit", "deg", *FIT_TS], ["a.csv"]),
    ("rig-header-field-over-csv-limit", rig_long_header, ["fit", "data.csv", "--scene", "rig.toml", "--out", "r.h5"],
     ["data.csv", "field larger than field limit"]),
    ("stiffening-k3-1e200", scene_effect("[effects.stiffening]\nk3 = 1e200"), ["simulate", "e.toml"],
     ["e.toml [effects.stiffening].k3", "1e+200"]),
    ("drag-D-1e200", scene_effect("[effects.drag]\nD = 1e200"), ["simulate", "e.toml"],
     ["e.toml [effects.drag].D", "1e+200"]),
    ("viscous-C-1e200", scene_effect("[effects.viscous]\nC = 1e200"), ["simulate", "e.toml"],
     ["e.toml [effects.viscous].C", "1e+200"]),
    ("line-break-in-a-file-name", newline_in_name, ["fit", "a\nswitching = 1\n#.csv", "--scene", "rig.toml"],
     ["a\\nswitching = 1\\n#.csv"]),
]


def fifo(name: str):
    def setup(w) -> None:
        import os

        os.mkfifo(w / name)
    return setup


def utf16(name: str, encoding: str):
    """The shipped sampled decay as UTF-16 text (with a byte-order mark, or without: utf-16-le)."""
    def setup(w) -> None:
        (w / name).write_bytes(TS.read_text().encode(encoding))
    return setup


def examples_with_a_fifo(w) -> None:
    """An examples folder whose last example file's place holds a FIFO (never replaced)."""
    import os

    from escfit.cli.examples import _files, examples_root

    last = _files(examples_root())[-1]
    (w / "ex" / last).parent.mkdir(parents=True)
    os.mkfifo(w / "ex" / last)


HOSTILE_FILES += [
    ("fifo-as-results-of-summary", fifo("q.h5"), ["summary", "q.h5"], ["q.h5: is a FIFO"]),
    ("fifo-as-results-of-report", fifo("q.h5"), ["report", "q.h5"], ["q.h5: is a FIFO"]),
    ("fifo-as-data-of-init", fifo("q.csv"), ["init", "q.csv"], ["q.csv: is a FIFO"]),
    ("utf16-time-series", utf16("u.csv", "utf-16"), ["fit", "u.csv", *FIT_TS], ["u.csv: UTF-16 text"]),
    ("utf16-time-series-without-mark", utf16("u.csv", "utf-16-le"), ["fit", "u.csv", *FIT_TS], ["u.csv: UTF-16 text"]),
    ("utf16-time-series-init", utf16("u.csv", "utf-16"), ["init", "u.csv"], ["u.csv: UTF-16 text"]),
    ("examples-force-over-a-fifo", examples_with_a_fifo, ["examples", "ex", "--force"], ["is a FIFO", "nothing was copied"]),
    # a channel written along one line (200000 readings, 2.4 MB): refused before any field is parsed
    ("one-line-of-readings-init", text_file("w.csv", ",".join(["0.123456789"] * 200_000)), ["init", "w.csv"],
     ["w.csv:1: about 200000 fields on a line", "--sample-rate"]),
    ("one-line-of-readings-fit", text_file("w.csv", ",".join(["0.123456789"] * 200_000)), ["fit", "w.csv", *FIT_TS],
     ["w.csv:1: about 200000 fields on a line", "--sample-rate"]),
]
