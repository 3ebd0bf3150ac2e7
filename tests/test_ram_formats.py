"""Xilinx .coe and Intel .mif RAM files: parsed back by small independent
readers written from the formats' documentation, they give the stream's
integers, word for word (I in the low half, signed 16-bit I and Q)."""

import json
import re

import numpy as np
import pytest

from rast.cli import main
from rast.model.config import parse_config
from rast.model.ramfiles import write_farm_files
from rast.model.stream import build_farm_streams

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
