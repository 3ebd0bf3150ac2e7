"""``rast load`` on a running block: live when the new streams fit beside the
playing ones (no channel muted, no playing word overwritten, each channel
switched at its old stream's period boundary), muted otherwise; a refused
switch leaves the old stream playing. Against the bit-exact model, with
time passing while the host waits."""

import json

import numpy as np
import pytest

from rast.load import RETRIES, LoadError, load_manifest, plan_writes, read_manifest_dir
from rast.model.contract.datapath import ONE, ReplayModel
from rast.model.contract.fixedpoint import ReplayContract, pack_iq
from rast.model.contract.hostproto import HostBridge
from rast.model.contract.regmap import CTRL_ENABLE, stream_crc32
from rast.sim.uart_chain import ModelBoard

FS = 1_000_000
INC = 5_000_000                     # a word every 859 samples (the FIR's fastest is ONE / 768)


def period(words):
    """Samples of one period of a stream of ``words`` at INC."""
    return -(-words * ONE // INC)
CONTRACT = ReplayContract(channels=3, pool_words=256, max_delay=120, max_tap=14, sample_rate_hz=FS)


class WatchedModel(ReplayModel):
    """The model, refusing (AssertionError) a stream word written over a
    stream a channel plays or will switch to, and counting the CTRL writes
    that turn a playing channel off."""

    def __init__(self, contract):
        super().__init__(contract)
        self.mutes = 0
        self.watching = True         # off for a muted load, which may overwrite

    def write(self, addr, value):
        r = self.rmap.by_addr(addr)
        if r is not None and r.name == "STREAM_DATA" and self.watching:
            a = self.stream_addr
            for l in range(self.c.channels):
                live = [(self.base_act[l], self.len_act[l])] if self.enable[l] else []
                if self.pending[l]:
                    live.append((self.base_next[l], self.len_next[l]))
                for base, n in live:
                    assert not 0 <= a - base < n, f"pool word {a} overwritten while channel {l} plays it"
        if r is not None and r.name == "CTRL" and self.enable[r.channel] and not value & CTRL_ENABLE:
            self.mutes += 1
        super().write(addr, value)


class Board:
    """A model board on which time passes: ``play(n)`` runs n samples, and the
    host's waits run the model for as long."""

    def __init__(self, contract=CONTRACT, model=WatchedModel):
        self.model = model(contract)
        self.transport = ModelBoard(self.model)
        self.bridge = HostBridge(self.transport)

    def play(self, n):
        self.model.run(np.zeros(n, dtype=np.int64), np.zeros(n, dtype=np.int64))

    def wait(self, seconds):
        self.play(max(1, round(seconds * FS)))

    def load(self, folder, **kw):
        return load_manifest(self.bridge, folder, CONTRACT if "contract" not in kw else kw.pop("contract"),
                             wait=self.wait, **kw)


def farm(folder, lengths, seed):
    """A `rast stream`-shaped manifest of random streams; returns their words."""
    folder.mkdir(parents=True)
    rng = np.random.default_rng(seed)
    wms, chans, words = [], [], []
    for k, n in enumerate(lengths):
        w = pack_iq(rng.integers(-20000, 20000, n), rng.integers(-20000, 20000, n))
        (folder / f"w{k}.hex").write_text("".join(f"{int(x):08x}\n" for x in w))
        wms.append({"name": f"w{k}", "hex_file": f"w{k}.hex", "length": n, "crc32": stream_crc32(w)})
        chans.append({"windmill": f"w{k}", "enable": 1, "length": n, "phase_increment": INC,
                      "gain": 1 << 16, "delay_samples": 100 + 2 * k})
        words.append([int(x) for x in w])
    (folder / "manifest.json").write_text(json.dumps(
        {"format": "rast-manifest/2", "windmills": wms, "registers": {"channels": chans}}))
    return words


def playing(model, ch):
    return [int(x) for x in model.stream_of(ch)]


def test_a_reload_that_fits_beside_the_playing_streams_mutes_nothing(tmp_path):
    b = Board()
    a_words = farm(tmp_path / "a", (40, 50, 30), seed=1)
    b_words = farm(tmp_path / "b", (45, 35, 50), seed=2)
    first = b.load(tmp_path / "a")
    assert first["live"] and first["switch_s"] == 0.0         # nothing played yet: switched at once
    b.play(500)
    assert [playing(b.model, ch) for ch in range(3)] == a_words
    steps = b.model.steps
    res = b.load(tmp_path / "b")
    assert res["live"] and res["muted_why"] is None and res["retries"] == []
    assert b.model.mutes == 0
    assert res["switch_s"] == pytest.approx(50 * ONE / INC / FS)       # the longest old period
    # done only once every channel switched: the load waited for the old periods to end
    assert not any(b.model.pending) and b.model.steps > steps
    assert [playing(b.model, ch) for ch in range(3)] == b_words


def test_a_reload_without_room_beside_is_muted_and_says_why(tmp_path):
    b = Board()
    farm(tmp_path / "a", (80, 80, 80), seed=1)
    b_words = farm(tmp_path / "b", (30, 30, 30), seed=2)      # 240 + 90 > 256
    b.load(tmp_path / "a")
    b.play(300)
    b.model.watching = False
    res = b.load(tmp_path / "b")
    assert not res["live"] and "do not fit beside the 240 words playing" in res["muted_why"]
    assert [playing(b.model, ch) for ch in range(3)] == b_words and not any(b.model.pending)


def damage_word(board, word, times):
    """The line flips bit 9 of stream word ``word`` the first ``times`` times it
    is sent (the frame still well formed: the block refuses the switch by the
    stream's CRC-32)."""
    apply, seen = board.transport._apply, []

    def damage(addr, value):
        if addr == board.model.rmap.addr("STREAM_DATA") and value == word and len(seen) < times:
            seen.append(value)
            value ^= 1 << 9
        apply(addr, value)
    board.transport._apply = damage
    return seen


@pytest.mark.parametrize("live", [True, False])
def test_a_switch_refused_once_is_sent_again_and_taken(tmp_path, live):
    """One word of channel 1's new stream damaged on the line once: the block
    refuses the switch, rast load sends the stream again, and the load is done
    with channel 1 on its new stream, saying what it sent again."""
    b = Board()
    farm(tmp_path / "a", (40, 50, 30), seed=1)
    b_words = farm(tmp_path / "b", (45, 35, 50), seed=2)
    b.load(tmp_path / "a")
    b.play(500)
    seen = damage_word(b, b_words[1][7], times=1)
    b.model.watching = live
    res = b.load(tmp_path / "b", live=live)
    assert len(seen) == 1 and res["retries"] == ["channel 1's stream (refused: the words it received differ "
                                                 "from the stream)"]
    assert not any(b.model.pending) and not any(b.model.rejected)
    assert [playing(b.model, ch) for ch in range(3)] == b_words


@pytest.mark.parametrize("live", [True, False])
def test_a_refused_switch_leaves_the_channel_as_the_load_says(tmp_path, live):
    """One word of channel 1's new stream is damaged on the line every time it
    is sent: after RETRIES more tries rast load gives up naming the channel;
    live, the channel goes on with its old stream and its registers name it
    again; muted, it is off."""
    b = Board()
    a_words = farm(tmp_path / "a", (40, 50, 30), seed=1)
    b_words = farm(tmp_path / "b", (45, 35, 50), seed=2)
    b.load(tmp_path / "a")
    b.play(500)
    seen = damage_word(b, b_words[1][7], times=RETRIES + 1)
    if not live:
        b.model.watching = False
    with pytest.raises(LoadError, match=f"channel 1 .* after {RETRIES + 1} tries .*"
                                        + ("go on as before the load, with their old streams" if live
                                           else "those channels are off")):
        b.load(tmp_path / "b", live=live)
    assert len(seen) == RETRIES + 1
    b.play(period(50) + 10)
    a = b.model.rmap.addr
    if live:
        assert playing(b.model, 1) == a_words[1] and b.model.enable[1]
        assert (b.bridge.read(a("LENGTH", 1)), b.bridge.read(a("PHASE_INC", 1))) == (50, INC)
        assert b.model.base_act[1] == b.bridge.read(a("BASE", 1))
    else:
        assert not b.model.enable[1]
    assert [playing(b.model, ch) for ch in (0, 2)] == [b_words[0], b_words[2]]


def test_a_load_waits_for_the_switches_an_earlier_load_left_pending(tmp_path):
    """B's switches are pending when C is loaded: the host waits for them (time
    passes) before it places C, so that C overwrites neither A (still playing)
    nor B."""
    b = Board()
    farm(tmp_path / "a", (40, 50, 30), seed=1)
    farm(tmp_path / "b", (45, 35, 50), seed=2)
    c_words = farm(tmp_path / "c", (20, 30, 25), seed=3)
    b.load(tmp_path / "a")
    b.play(500)
    # B's writes sent by a load that was cut off before it saw them take effect
    manifest, words = read_manifest_dir(tmp_path / "b")
    b.bridge.write_many(plan_writes(manifest, CONTRACT, words, [(0, 40), (40, 50), (90, 30)]))
    assert all(b.model.pending)
    steps = b.model.steps
    res = b.load(tmp_path / "c")
    assert res["live"] and b.model.steps > steps and b.model.mutes == 0
    b.play(period(50) + 10)
    assert [playing(b.model, ch) for ch in range(3)] == c_words
