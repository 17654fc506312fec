"""Talking heads from text (issue 23): eSpeak NG's phonemes at their samples become
visemes that blend, lips that shut, a jaw that follows the vowels, silence that is
neutral; the stream lasts as long as the sound; the command writes every output."""
from __future__ import annotations

import sys

import numpy as np
import pytest
from click.testing import CliRunner

from mpeg4fba.cli import main
from mpeg4fba.fba.tables import VISEMES
from mpeg4fba.formats.errors import FormatError
from mpeg4fba.formats.wav import dumps_wav, loads_wav, read_wav

speech = pytest.importorskip("mpeg4fba.speech")
if not speech.available():
    pytest.skip("the speech extra (espeakng-loader) is not installed", allow_module_level=True)

PP, FF, IH, NONE = VISEMES["PP"].number, VISEMES["FF"].number, VISEMES["ih"].number, 0


def _dominant(stream) -> np.ndarray:
    """The viseme with the larger share in each frame."""
    s1, s2, blend = stream.visemes[:, 0], stream.visemes[:, 1], stream.visemes[:, 2]
    return np.where(blend >= 32, s1, s2)


def _runs(values: np.ndarray) -> list:
    """The values of the runs of equal neighbours."""
    keep = np.append(True, values[1:] != values[:-1])
    return values[keep].tolist()


def _shut(stream) -> np.ndarray:
    """Frames where the lips are fully shut: PP at its whole share."""
    v = stream.visemes
    return ((v[:, 0] == PP) & (v[:, 2] == 63)) | ((v[:, 1] == PP) & (v[:, 2] == 0))


@pytest.mark.parametrize("fps", [25, 30, 60])
def test_papa_shuts_the_lips_twice(fps):
    u = speech.say("papa", fps=fps)
    shut = _shut(u.stream).astype(int)
    assert int((np.diff(np.append(0, shut)) == 1).sum()) == 2
    jaw = u.stream.values[:, 2]
    assert (jaw[shut == 1] == 0).all()                      # and the jaw closes with them
    assert jaw.max() > 100                                  # the a's open it


def test_fee_shows_ff_then_a_spread_vowel():
    u = speech.say("fee")
    seq = [v for v in _runs(_dominant(u.stream)) if v != NONE]
    assert seq == [FF, IH]


def test_the_stream_lasts_as_long_as_the_sound():
    for text, fps in (("Hello! I am a cloned face.", 25), ("One, two. Three?", 30),
                      ("The quick brown fox jumps over the lazy dog.", 24)):
        u = speech.say(text, fps=fps)
        assert abs(u.stream.duration - u.duration) <= 1 / fps
        assert u.stream.fps == fps and len(u.samples) > 0


@pytest.mark.parametrize("text, voice", [("The quick brown fox jumps over the lazy dog.", "en"),
                                         ("She sells sea shells, by the sea shore.", "en-us"),
                                         ("Guten Tag, wie geht es Ihnen?", "de")])
def test_every_viseme_begins_within_a_frame_of_its_phoneme(text, voice):
    """Each phoneme whose viseme differs from the one before and that lasts a frame or
    more: its viseme is the larger share at some frame within 1/fps of its sample."""
    fps = 25
    u = speech.say(text, voice=voice, fps=fps)
    a, vis, _, _ = speech.segments(u.phonemes, u.sample_rate, len(u.samples))
    dom = _dominant(u.stream)
    t = u.stream.times
    ends = np.append(a[1:], u.duration)
    checked = 0
    for j in range(1, len(a)):
        if vis[j] == vis[j - 1] or ends[j] - a[j] < 1 / fps:
            continue
        near = np.abs(t - a[j]) <= 1 / fps + 1e-9
        assert (dom[near] == vis[j]).any(), (j, a[j], vis[j], dom[near])
        checked += 1
    assert checked >= 8


def test_pauses_are_neutral():
    u = speech.say("Yes. No. Maybe, then.")
    t = u.stream.times
    checked = 0
    for p in u.phonemes:
        if not p.name.startswith("_"):
            continue
        start = p.sample / u.sample_rate
        later = [q.sample / u.sample_rate for q in u.phonemes if q.sample > p.sample]
        end = min(later) if later else u.duration
        inside = (t > start + 0.06) & (t < end - 0.06)   # past the blends at either end
        if inside.any():
            assert (_dominant(u.stream)[inside] == NONE).all()
            assert (u.stream.values[inside, 2] == 0).all()
            checked += 1
    assert checked >= 2


def test_an_expression_is_held_and_options_are_checked():
    u = speech.say("Hello", expression="joy", intensity=50)
    assert (u.stream.expressions[:, :2] == [1, 50]).all() and u.stream.mask[:, 1].all()
    with pytest.raises(speech.SpeechError, match="no expression 'glee'"):
        speech.say("Hello", expression="glee")
    with pytest.raises(speech.SpeechError, match="no voice 'xx-yy'"):
        speech.say("Hello", voice="xx-yy")
    with pytest.raises(speech.SpeechError, match="empty"):
        speech.say("   ")
    with pytest.raises(speech.SpeechError, match="words a minute"):
        speech.say("Hello", rate=10)


def test_other_languages_go_through_the_fallback():
    u = speech.say("Bonjour, je m'appelle Marie.", voice="fr")
    shapes = [speech.phoneme_shape(p.name) for p in u.phonemes]
    assert any(not s.listed for s in shapes)                   # French phonemes not in the table
    assert all(0 <= s.viseme <= 14 and s.kind in speech.phonemes.KINDS for s in shapes)
    assert len(set(_dominant(u.stream).tolist())) >= 5


def test_every_table_phoneme_is_well_formed():
    table = speech.phoneme_table()
    assert len(table) >= 60
    for name, s in table.items():
        assert 0 <= s.viseme <= 14 and 0 <= s.jaw <= 1 and s.kind in speech.phonemes.KINDS, name
        assert (s.viseme2 is None) == (s.jaw2 is None)
    assert {table[k].kind for k in ("p", "b", "m")} == {"closure"}
    # every phoneme eSpeak's English voices speak is listed
    text = ("The beige hue on the waters of the loch impressed all, including the French queen, "
            "before she heard that symphony again, just as young Arthur wanted. Our boy enjoys "
            "a choice toy; air, ear, poor tour, hour, fire, singer, button, bottle, usual.")
    for voice in ("en", "en-us"):
        names = {p.name.lstrip("',") for p in speech.synthesize(text, voice=voice).phonemes}
        assert names <= set(table), (voice, names - set(table))


def test_without_the_extra_say_names_it(monkeypatch):
    from mpeg4fba.speech import engine
    monkeypatch.setattr(engine, "_engine", None)
    monkeypatch.setitem(sys.modules, "espeakng_loader", None)
    with pytest.raises(speech.SpeechUnavailable, match=r'mpeg4fba\[speech\]'):
        speech.say("Hello")
    r = CliRunner().invoke(main, ["say", "Hello", "-o", "x.wav"])
    assert r.exit_code == 1 and 'pip install "mpeg4fba[speech]"' in r.output


def test_the_command_writes_each_output(tmp_path):
    from mpeg4fba.formats.fap import read_fap
    from mpeg4fba.render.player import embedded_glb

    r = CliRunner().invoke(main, ["say", "Hello there", "-o", str(tmp_path / "a.fap")])
    assert r.exit_code == 0, r.output
    stream = read_fap(tmp_path / "a.fap")
    samples, rate = read_wav(tmp_path / "a.wav")
    assert abs(stream.duration - len(samples) / rate) <= 1 / stream.fps
    r = CliRunner().invoke(main, ["say", "Hi", "-o", str(tmp_path / "b.glb"), "--fps", "30"])
    assert r.exit_code == 0 and (tmp_path / "b.wav").exists(), r.output
    r = CliRunner().invoke(main, ["say", "Hi", "-o", str(tmp_path / "c.html"), "--expression", "joy"])
    page = (tmp_path / "c.html").read_text()
    assert r.exit_code == 0 and 'id="audio"' in page and "data:audio/wav;base64," in page
    assert embedded_glb(page)[:4] == b"glTF"
    r = CliRunner().invoke(main, ["say", "Hi", "-o", str(tmp_path / "frames"), "--frames", "0:2",
                                  "--size", "64x80"])
    assert r.exit_code == 0, r.output
    assert sorted(p.name for p in (tmp_path / "frames").iterdir()) == \
        ["frame_0000.png", "frame_0001.png", "speech.wav"]
    r = CliRunner().invoke(main, ["say", "Hi", "-o", str(tmp_path / "d.mp3")])
    assert r.exit_code == 2 and ".mp3" in r.output


def test_wav_round_trip_and_damage():
    samples = (np.sin(np.arange(800) / 9) * 20000).astype(np.int16)
    data = dumps_wav(samples, 16000)
    back, rate = loads_wav(data)
    assert rate == 16000 and np.array_equal(back, samples)
    for bad, what in ((data[:10], "RIFF"), (data[:12], "no 'fmt '"),
                      (data[:20] + b"\x03\x00" + data[22:], "format 3")):
        with pytest.raises(FormatError, match=what) as e:
            loads_wav(bad, "x.wav")
        assert e.value.path == "x.wav"


# --------------------------------------------------------------------------- in Chromium

def test_the_player_plays_the_sound_in_step(tmp_path):
    """The page plays with sound allowed: after a few seconds the audio element's time
    and the animation's agree within 1/fps; the mouth differs between a shut p and an
    open a."""
    import io

    from _browser import CHROMIUM, CHROMIUM_ARGS, browser_missing
    from matplotlib import image as mimage

    from mpeg4fba.formats.gltf import dumps_glb
    from mpeg4fba.models import reference_head
    from mpeg4fba.render.player import write_player

    why = browser_missing()
    if why:
        pytest.skip(why)
    from playwright.sync_api import sync_playwright

    fps = 25
    u = speech.say("Papa, papa! Part a pop art party at the park, papa. We will play all "
                   "afternoon, and then we will walk home by the river, papa.", fps=fps)
    assert u.duration > 6
    face = reference_head(resolution=0.5)
    path = write_player(dumps_glb(face, u.stream), tmp_path / "say.html", title="say",
                        audio=dumps_wav(u.samples, u.sample_rate))
    shut = np.flatnonzero(_shut(u.stream))
    wide = np.flatnonzero((_dominant(u.stream) == VISEMES["aa"].number) & (u.stream.values[:, 2] > 100))
    assert len(shut) and len(wide)
    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM,
                              args=CHROMIUM_ARGS + ["--autoplay-policy=no-user-gesture-required"])
        try:
            page = b.new_page(viewport={"width": 480, "height": 400})
            errors = []
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.goto(path.as_uri())
            page.wait_for_function('document.body.dataset.ready === "1" || !!document.body.dataset.error',
                                   timeout=60_000)
            assert page.evaluate("document.body.dataset.error || ''") == ""
            seen = []
            for _ in range(3):
                page.wait_for_timeout(1000)
                # read in an animation frame, after the player's own has set the face
                state = page.evaluate("""() => new Promise(r => requestAnimationFrame(() => r({
                    audio: __player.audioTime(), anim: __player.currentTime(),
                    playing: __player.playing()})))""")
                assert state["playing"], state
                assert abs(state["audio"] - state["anim"]) <= 1 / fps, state
                seen.append(state["audio"])
            assert seen[0] < seen[1] < seen[2] and seen[2] > 2.0, seen      # the sound plays on
            # scrubbing moves both
            page.evaluate("__player.pause(); __player.setTime(0.5)")
            both = page.evaluate("[__player.audioTime(), __player.currentTime()]")
            assert both == pytest.approx([0.5, 0.5], abs=1e-3)

            def mouth_at(frame: int) -> np.ndarray:
                page.evaluate(f"__player.setTime({frame / fps})")
                page.evaluate("() => new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)))")
                png = page.screenshot()
                return (mimage.imread(io.BytesIO(png), format="png")[..., :3] * 255).round()

            closed, opened = mouth_at(int(shut[0])), mouth_at(int(wide[0]))
            changed = np.abs(closed - opened).sum(-1) > 40
            rows, cols = np.nonzero(changed[:356, :230])       # the view, not the panel or bar
            assert len(rows) > 50
            # the change is in the mouth: the lower middle of the face
            face_rows = np.nonzero((np.abs(closed[:356, :230] - closed[5, 5]).sum(-1) > 40).any(1))[0]
            middle = (face_rows.min() + face_rows.max()) / 2
            assert np.median(rows) > middle
            assert errors == []
        finally:
            b.close()


def test_the_demo_speaks_its_phrase_or_falls_back_to_the_silent_one(monkeypatch):
    from mpeg4fba.cli.demo import demo_phrase
    from mpeg4fba.models.phrase import PHRASE_TEXT, demo_stream
    from mpeg4fba.speech import engine

    stream, wav = demo_phrase()
    samples, rate = loads_wav(wav)
    assert abs(stream.duration - len(samples) / rate) <= 1 / stream.fps
    assert stream.mask[:, 1].all() and stream.values[:, 18].any()     # joy arc, blinks
    # spoken again: eSpeak's timing may differ by some milliseconds between calls
    assert abs(len(speech.say(PHRASE_TEXT).stream) - len(stream)) <= 1
    monkeypatch.setattr(engine, "_engine", None)
    monkeypatch.setitem(sys.modules, "espeakng_loader", None)
    stream, wav = demo_phrase()
    assert wav is None and stream == demo_stream()


def test_blinks_and_head_motion_unless_still():
    text = "A longer sentence, so that the face has time to blink more than once or twice."
    still = speech.say(text, life=False).stream
    assert not still.mask[:, [18, 47, 48]].any()
    alive = speech.with_blinks_and_head(still, seed=3)
    assert np.array_equal(alive.visemes, still.visemes)            # the mouth alike
    assert np.array_equal(alive.values[:, 2], still.values[:, 2])
    lid = alive.values[:, 18]
    blinks = int((np.diff((lid > 500).astype(int)) == 1).sum())
    assert blinks >= 2 and alive.duration / blinks < 5.5
    head = alive.values[:, [47, 48]]
    assert 0 < np.abs(head).max() <= 5000 and np.abs(head[[0, -1]]).max() < 500   # rests at both ends
    assert speech.say(text).stream.mask[:, [18, 19, 47, 48]].all()       # on by default
