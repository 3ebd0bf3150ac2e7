"""RAM files: Xilinx .coe and Intel .mif parsed back by small independent
readers written from the formats' documentation give the stream's integers,
word for word (I in the low half, signed 16-bit I and Q); the .hex, .bin and
.npy files written while the streams are computed are byte for byte those of
the plain formulations (f-strings, struct, np.save)."""

import dataclasses
import json
import re
import zlib

import numpy as np
import pytest

from rast.cli import main
from rast.model.physics.config import ConfigError
from rast.model.physics.farm import parse_config
from rast.model.contract.fixedpoint import STREAM, pack_iq
from rast.model.files.ramfiles import FORMATS, write_farm_files
from rast.model.physics.stream import build_farm_streams

CONFIG = {"sample_rate": 20, "radar_frequency": 5350,
          "windmill": [{"name": "w", "range": 2.0, "num_blades": 3, "rpm": 15,
                        "radius": [26.0, 13.0], "rsc": [1.0, 0.5]}]}


def parse_coe(text):
    """Xilinx COE: '; comments', 'memory_initialization_radix=R;' and
    'memory_initialization_vector=' followed by values separated by commas
    or white space, ended by ';'."""
    text = "\n".join(line.split(";", 1)[0] if line.lstrip().startswith(";") else line
                     for line in text.splitlines())
    radix = int(re.search(r"memory_initialization_radix\s*=\s*(\d+)\s*;", text).group(1))
    vector = re.search(r"memory_initialization_vector\s*=\s*([^;]*);", text).group(1)
    return [int(v, radix) for v in re.split(r"[,\s]+", vector.strip()) if v]


def parse_mif(text):
    """Intel MIF: '-- comments', WIDTH, DEPTH, the radixes, and
    'CONTENT BEGIN ... END;' with 'address : value;' lines."""
    text = re.sub(r"--[^\n]*", "", text)
    header = dict(re.findall(r"(\w+)\s*=\s*(\w+)\s*;", text.split("CONTENT")[0]))
    radix = {"HEX": 16, "UNS": 10, "DEC": 10, "BIN": 2, "OCT": 8}
    body = re.search(r"CONTENT\s+BEGIN(.*)END\s*;", text, re.S).group(1)
    memory = {}
    for address, value in re.findall(r"(\w+)\s*:\s*(\w+)\s*;", body):
        memory[int(address, radix[header["ADDRESS_RADIX"]])] = int(value, radix[header["DATA_RADIX"]])
    depth = int(header["DEPTH"])
    assert int(header["WIDTH"]) == 32
    assert sorted(memory) == list(range(depth))
    return [memory[a] for a in range(depth)]


@pytest.fixture(scope="module")
def streams():
    return build_farm_streams(parse_config(CONFIG))


def test_coe_and_mif_give_back_the_stream_integers(streams, tmp_path):
    written = write_farm_files(streams, tmp_path, formats=("coe", "mif"))
    s = streams.streams[0]
    for name, parse in (("w.coe", parse_coe), ("w.mif", parse_mif)):
        words = np.array(parse(written[name].read_text()), dtype=np.int64)
        assert words.size == s.plan.length
        # Unpack by hand: I is the low 16 bits, Q the high 16, both two's complement.
        i = ((words & 0xFFFF) ^ 0x8000) - 0x8000
        q = (((words >> 16) & 0xFFFF) ^ 0x8000) - 0x8000
        np.testing.assert_array_equal(i, s.i)
        np.testing.assert_array_equal(q, s.q)
    assert set(written) == {"w.hex", "w.coe", "w.mif", "manifest.json"}   # hex always, no bin/npy
    entry = json.loads(written["manifest.json"].read_text())["windmills"][0]
    assert (entry["coe_file"], entry["mif_file"], entry["hex_file"]) == ("w.coe", "w.mif", "w.hex")
    assert "bin_file" not in entry


def test_coe_vector_is_comma_separated_and_ends_with_a_semicolon(streams, tmp_path):
    written = write_farm_files(streams, tmp_path, formats=("coe",))
    lines = written["w.coe"].read_text().splitlines()
    vector = lines[lines.index("memory_initialization_vector=") + 1:]
    assert all(line.endswith(",") for line in vector[:-1]) and vector[-1].endswith(";")
    assert len(vector) == streams.streams[0].plan.length


def test_default_formats_are_unchanged(streams, tmp_path):
    written = write_farm_files(streams, tmp_path)
    assert set(written) == {"w.hex", "w.bin", "w.npy", "manifest.json"}


def test_cli_format_option(tmp_path, capsys):
    config = tmp_path / "farm.toml"
    config.write_text('sample_rate = 20\nradar_frequency = 5350\n[[windmill]]\nname = "w"\nrange = 2.0\n'
                      'num_blades = 3\nrpm = 15\nradius = [26.0]\nrsc = [1.0]\n')
    assert main(["stream", str(config), "--out", str(tmp_path / "out"), "--format", "mif,coe"]) == 0
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == [
        "manifest.json", "w.coe", "w.hex", "w.mif"]
    hex_words = [int(line, 16) for line in (tmp_path / "out" / "w.hex").read_text().split()]
    assert parse_mif((tmp_path / "out" / "w.mif").read_text()) == hex_words
    assert parse_coe((tmp_path / "out" / "w.coe").read_text()) == hex_words


def test_cli_unknown_format_is_a_user_error(tmp_path, capsys):
    config = tmp_path / "farm.toml"
    config.write_text('sample_rate = 20\nradar_frequency = 5350\nrange = 2.0\nnum_blades = 3\nrpm = 15\n'
                      'radius = [26.0]\nrsc = [1.0]\n')
    with pytest.raises(SystemExit) as info:
        main(["stream", str(config), "--out", str(tmp_path / "out"), "--format", "hex,xlsx"])
    assert info.value.code == 2
    assert "--format" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


# ----------------------------------------------------- the writers' bytes
# The files are the hardware's contract: the fast writers must give the bytes
# of the plain formulations they replaced, on any block boundary.

def previous_hex(words):
    """The .hex writer before the table look-up: bytes.hex of the big-endian words."""
    words = np.asarray(words, dtype=np.int64)
    return words.astype(">u4").tobytes().hex("\n", 4).encode("ascii") + b"\n" if words.size else b""


def test_hex_writer_gives_the_previous_writers_bytes_on_every_block_boundary(tmp_path, monkeypatch):
    from rast.model.files import ramfiles
    monkeypatch.setattr(ramfiles, "_HEX_BLOCK", 1000)
    rng = np.random.default_rng(11)
    edges = [0, 1, 9, 10, 15, 16, 0xFFFF, 0x10000, 0x7FFFFFFF, 0x80000000, 0xFFFFFFFE, 0xFFFFFFFF]
    for size in (0, 1, 999, 1000, 1001, 3 * 1000 + 17):
        words = np.concatenate([edges, rng.integers(0, 1 << 32, size)])[:max(size, 0) or 0]
        words = np.asarray(words, dtype=np.int64)
        for form in (words, words.astype(np.uint32), words.astype("<u4")):
            ramfiles.write_hex(form, tmp_path / "w.hex")
            data = (tmp_path / "w.hex").read_bytes()
            assert data == previous_hex(words)
            assert data == "".join(f"{int(w):08x}\n" for w in words).encode("ascii")


def stream_farm(interpolation, rates):
    """Windmills with flashes, wire and tower at the given stream rates (None: automatic)."""
    rng = np.random.default_rng(4)
    windmills = []
    for k, rate in enumerate(rates):
        w = {"name": f"w{k}", "range": 2.0 + k, "num_blades": 3, "rpm": 15 + 3 * k, "num_rcs": 4,
             "radius": [6.0, 12.0, 18.0, 24.0], "rsc": list(rng.uniform(0.2, 1.5, 4)),
             "phase_start": list(rng.uniform(0, 360, 4)),
             "rsc_weighting": {"angle": [0, 180], "width": 8, "gain_db": 10},
             "wire_enable": True, "wire_radius_min": 2.0, "wire_radius_max": 24.0,
             "wire_reflectivity": 0.02, "tower_rcs": 5.0}
        if rate is not None:
            w["stream_rate"] = rate
        windmills.append(w)
    return parse_config({"sample_rate": 20, "radar_frequency": 5350, "interpolation": interpolation,
                         "windmill": windmills})


def small_blocks(monkeypatch):
    """Every piece of the computation and of the writing small, with ragged ends."""
    from rast.model.files import ramfiles
    from rast.model.physics import stream
    from rast.model.physics import synthesis
    from rast.model.physics.turbine import CHUNK_SAMPLES
    monkeypatch.setattr(synthesis, "SAMPLES_PER_BLOCK", 5003)
    monkeypatch.setattr(synthesis, "SAMPLES_PER_PIECE", 2 * CHUNK_SAMPLES)
    monkeypatch.setattr(stream, "_QUANTISE_BLOCK", 7001)
    monkeypatch.setattr(stream, "_PARALLEL_WITHIN", 20000)
    monkeypatch.setattr(ramfiles, "_HEX_BLOCK", 1009)
    monkeypatch.setattr(ramfiles, "_DIRECT_MIN_BYTES", 0)          # every file through O_DIRECT
    monkeypatch.setattr(ramfiles, "_DIRECT_BUFFER", 3 * ramfiles._ALIGN)


@pytest.mark.parametrize("interpolation, rates", [
    ("hold", [2e6, None, 3e5]),          # a grid stream in pieces, a short one, a direct one in pieces
    ("fir", [None, None, 20_000.0]),     # the FIR's headroom rescales, then the words are written
])
def test_files_written_while_computing_are_the_plain_writers_bytes(tmp_path, monkeypatch, interpolation, rates):
    import struct
    from rast.model.files.ramfiles import make_farm_files
    small_blocks(monkeypatch)
    farm = stream_farm(interpolation, rates)
    fs, written = make_farm_files(farm, tmp_path / "made", formats=FORMATS)
    if interpolation == "hold":
        assert [s.synthesis.method for s in fs.streams] == ["grid", "direct", "direct"]
    else:                             # rescaled below full scale for the FIR's overshoot
        peaks = [max(np.abs(s.period.real).max(), np.abs(s.period.imag).max()) for s in fs.streams]
        assert any(s.scale < STREAM.max / p * (1 - 1e-9) for s, p in zip(fs.streams, peaks))
    later = write_farm_files(build_farm_streams(farm), tmp_path / "later", formats=FORMATS)
    assert sorted(written) == sorted(later)
    for name in written:
        assert written[name].read_bytes() == later[name].read_bytes(), name
    for s in fs.streams:
        name = s.windmill.name
        words = [int(w) for w in pack_iq(s.i, s.q)]
        assert written[f"{name}.hex"].read_bytes() == "".join(f"{w:08x}\n" for w in words).encode()
        assert written[f"{name}.bin"].read_bytes() == struct.pack(f"<{len(words)}I", *words)
        entry = next(e for e in json.loads(written["manifest.json"].read_text())["windmills"] if e["name"] == name)
        assert entry["crc32"] == zlib.crc32(struct.pack(f"<{len(words)}I", *words))
        saved = tmp_path / "saved.npy"
        np.save(saved, np.array(s.period))
        assert written[f"{name}.npy"].read_bytes() == saved.read_bytes()


def test_make_farm_files_reports_progress_up_to_every_windmills_length(tmp_path):
    from rast.model.files.ramfiles import make_farm_files
    farm = stream_farm("hold", [2e6, None])
    seen = {}

    def progress(name, done, total):
        assert done >= seen.get(name, 0) and done <= total
        seen[name] = done

    fs, _ = make_farm_files(farm, tmp_path / "out", progress=progress)
    assert seen == {s.windmill.name: s.plan.length for s in fs.streams}


def test_make_farm_files_leaves_nothing_when_it_fails(tmp_path):
    from rast.model.files.ramfiles import make_farm_files
    farm = stream_farm("hold", [2e6, None])

    def refuse(farm_streams):
        raise RuntimeError("does not fit")

    fresh = tmp_path / "a" / "b"
    with pytest.raises(RuntimeError):
        make_farm_files(farm, fresh, check=refuse)
    assert not (tmp_path / "a").exists()
    kept = tmp_path / "kept"
    kept.mkdir()
    (kept / "old.txt").write_text("x")
    with pytest.raises(RuntimeError):
        make_farm_files(farm, kept, check=refuse)
    assert [p.name for p in kept.iterdir()] == ["old.txt"]
    with pytest.raises(ConfigError):                      # refused before any work
        make_farm_files(dataclasses.replace(farm, ram_depth=100), tmp_path / "c")
    assert not (tmp_path / "c").exists()


def test_a_file_written_in_pieces_past_the_page_cache_has_every_byte(tmp_path, monkeypatch):
    import os
    from rast.model.files import ramfiles
    monkeypatch.setattr(ramfiles, "_DIRECT_BUFFER", 2 * ramfiles._ALIGN)
    try:                                   # can this file system take O_DIRECT at all?
        os.close(os.open(tmp_path / "probe", os.O_WRONLY | os.O_CREAT | os.O_DIRECT))
        direct = True
    except (AttributeError, OSError):
        direct = False
    rng = np.random.default_rng(9)
    for total in (0, 1, 4095, 4096, 4097, 3 * 8192 + 5):
        data = rng.integers(0, 256, total, dtype=np.uint8).tobytes()
        out = ramfiles._OutFile(tmp_path / "f.bin", size=1 << 40)
        assert out.direct == direct
        k = 0
        while k < total:                   # pieces of every size, across the buffer's edges
            n = int(rng.integers(1, 3 * 4096))
            out.write(data[k:k + n])
            k += n
        out.close()
        assert (tmp_path / "f.bin").read_bytes() == data


def test_a_file_system_that_refuses_o_direct_at_the_first_write_gets_plain_writes(tmp_path, monkeypatch):
    import errno
    import os
    from rast.model.files import ramfiles
    monkeypatch.setattr(ramfiles, "_DIRECT_BUFFER", ramfiles._ALIGN)
    out = ramfiles._OutFile(tmp_path / "f.bin", size=1 << 40)
    if not out.direct:
        out.close()
        pytest.skip("this file system refuses O_DIRECT when the file is opened")
    real, calls = os.write, []

    def write(fd, data):                  # the first write refused, as some file systems do
        calls.append(len(data))
        if len(calls) == 1:
            raise OSError(errno.EINVAL, "Invalid argument")
        return real(fd, data)

    monkeypatch.setattr(os, "write", write)
    data = np.random.default_rng(2).integers(0, 256, 3 * 4096 + 100, dtype=np.uint8).tobytes()
    out.write(data[:5000])
    out.write(data[5000:])
    out.close()
    assert len(calls) > 1 and not out.direct
    assert (tmp_path / "f.bin").read_bytes() == data
