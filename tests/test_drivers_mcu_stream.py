"""The microcontroller line protocol: checksum, encoding, robust parsing and clock mapping."""
import re
from pathlib import Path

import numpy as np
import pytest

from sensor.drivers import DeviceDisconnectedError, MicrocontrollerStream, mcu_stream
from sensor.drivers.device_clock import DeviceClockMapper
from sensor.drivers.mcu_stream import (LineError, StreamRecord, checksum, encode_record,
                                       parse_line)
from sensor.emulators import FakeClock, FakeMicrocontrollerSerial, Fault

RECORD = StreamRecord(123456, 100_234.56, 24.31, np.array([0.5, 0.5, -0.5, 0.5]),
                      np.array([0.012, -0.5, 1.25]), np.array([0.0, 0.098, 9.806]))


def test_checksum_is_the_nmea_xor():
    # The NMEA 0183 GGA example sentence carries checksum 0x47.
    assert checksum(b"GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,") == 0x47


def test_a_hand_written_line_parses():
    body = b"T,42,101325.00,25.00,1,0,0,0,0.1,0.2,0.3,0,0,9.81"
    parsed = parse_line(b"$" + body + b"*%02X\r" % checksum(body))
    assert parsed.t_device_ms == 42 and parsed.pressure_pa == 101325.0
    assert parsed.quat_wxyz == pytest.approx([1, 0, 0, 0])
    assert parsed.lin_acc_mps2 == pytest.approx([0.1, 0.2, 0.3])
    assert parsed.gravity_mps2 == pytest.approx([0, 0, 9.81])


def test_the_protocol_documents_examples_parse():
    doc = Path(mcu_stream.__file__).with_name("mcu_stream_protocol.md").read_text()
    examples = [m.encode() for m in re.findall(r"\$[TI],[^`\n<]*?\*[0-9A-F]{2}", doc)]
    assert len(examples) == 2
    record, info = parse_line(examples[0]), parse_line(examples[1])
    assert record.t_device_ms == 583201 and record.gravity_mps2 == pytest.approx([-1.703, 0, 9.657])
    assert info.startswith("fw 1.0")


def test_encoding_round_trips_to_the_printed_precision():
    line = encode_record(RECORD)
    assert line.startswith(b"$T,123456,100234.56,24.31,") and line.endswith(b"\r\n")
    parsed = parse_line(line[:-1])
    assert parsed.t_device_ms == RECORD.t_device_ms
    assert parsed.pressure_pa == pytest.approx(RECORD.pressure_pa, abs=0.005)
    assert parsed.temperature_c == pytest.approx(RECORD.temperature_c, abs=0.005)
    assert parsed.quat_wxyz == pytest.approx(RECORD.quat_wxyz, abs=1e-5)
    assert parsed.lin_acc_mps2 == pytest.approx(RECORD.lin_acc_mps2, abs=5e-4)
    assert parsed.gravity_mps2 == pytest.approx(RECORD.gravity_mps2, abs=5e-4)


def corrupt(line, index, value):
    damaged = bytearray(line)
    damaged[index] = value
    return bytes(damaged)


GOOD = encode_record(RECORD).rstrip(b"\r\n")


def frame(body: bytes) -> bytes:
    return b"$" + body + b"*%02X" % checksum(body)


@pytest.mark.parametrize("line, kind", [
    (corrupt(GOOD, 10, ord("9")), "checksum_errors"),  # a flipped digit
    (GOOD[:-3], "malformed"),  # checksum cut off
    (GOOD[:40], "malformed"),  # truncated line
    (b"\xff\xfe\x00garbage", "malformed"),
    (frame(b"T,1,2,3"), "malformed"),  # too few fields
    (frame(b"T,-5,101325,25,1,0,0,0,0,0,0,0,0,9.8"), "malformed"),  # negative time
    (frame(b"T,5,nan,25,1,0,0,0,0,0,0,0,0,9.8"), "implausible"),
    (frame(b"T,5,101325,25,0,0,0,0,0,0,0,0,0,9.8"), "implausible"),  # zero quaternion
    (frame(b"T,5,101325,300,1,0,0,0,0,0,0,0,0,9.8"), "implausible"),  # 300 C
    (frame(b"X,1,2"), "unknown_sentences"),
    (frame("T,5,1013\u00e9,25".encode("latin-1")), "malformed"),  # non-ASCII
])
def test_bad_lines_are_rejected_with_a_reason(line, kind):
    with pytest.raises(LineError) as info:
        parse_line(line)
    assert info.value.kind == kind


def make_stream(**options):
    clock = FakeClock(100.0)
    port = FakeMicrocontrollerSerial(clock=clock)
    return MicrocontrollerStream(port, clock=clock.monotonic, **options), port, clock


def test_stream_skips_and_counts_corruption_and_keeps_good_lines():
    stream, port, _ = make_stream()
    port.queue_sample(1000, 100_000.0)
    port.queue_bytes(corrupt(GOOD, 12, ord("7")) + b"\r\n")  # checksum error
    port.queue_bytes(b"\x00\x13\xfe noise without newline then " + GOOD + b"\r\n")  # '$' resync
    port.queue_info("firmware 1.4, BMP280 x4, BNO055 NDOF")
    port.queue_bytes(b"A" * 600)  # a runaway line ...
    port.queue_bytes(b"tail\n")  # ... whose end is dropped with it
    port.queue_sample(1010, 100_010.0)
    records = stream.poll() + stream.poll()
    assert [r.t_device_ms for r in records] == [1000, RECORD.t_device_ms, 1010]
    stats = stream.stats
    assert (stats.records, stats.checksum_errors, stats.oversized, stats.info_lines) == (3, 1, 1, 1)
    assert stats.skipped == 2
    assert stats.last_info == "firmware 1.4, BMP280 x4, BNO055 NDOF"


def test_random_noise_never_raises_and_loses_no_intact_line():
    rng = np.random.default_rng(7)
    stream, port, _ = make_stream()
    sent = 0
    for i in range(300):
        if rng.random() < 0.5:
            noise = bytes(rng.integers(0, 256, rng.integers(1, 80), dtype=np.uint8))
            port.queue_bytes(noise.replace(b"\n", b"") + b"\n")
        else:
            port.queue_sample(i, 95_000.0 + i)
            sent += 1
    records = []
    for _ in range(200):
        records += stream.poll()
    assert len(records) == sent
    assert [r.pressure_pa for r in records] == sorted(r.pressure_pa for r in records)
    assert stream.stats.records == sent


def test_chunk_boundaries_do_not_matter():
    stream_whole, port, _ = make_stream()
    for i in range(20):
        port.queue_sample(i * 10, 100_000.0 + i)
    data = port.read(1 << 16)
    whole = stream_whole.feed(data, 1.0)
    stream_split, _, _ = make_stream()
    split = []
    for start in range(0, len(data), 7):
        split += stream_split.feed(data[start:start + 7], 1.0)
    assert [r.pressure_pa for r in split] == [r.pressure_pa for r in whole]
    assert len(whole) == 20


def test_disconnect_is_a_named_error():
    stream, port, _ = make_stream()
    port.faults.inject(Fault.DISCONNECT)
    with pytest.raises(DeviceDisconnectedError, match="microcontroller stream"):
        stream.poll()


def test_port_and_options_are_checked():
    with pytest.raises(TypeError, match="read"):
        MicrocontrollerStream(object())
    with pytest.raises(ValueError, match="max_line_bytes"):
        MicrocontrollerStream(FakeMicrocontrollerSerial(), max_line_bytes=10)


# -- device clock to host clock ----------------------------------------------------------------

def simulate(mapper, seconds, rate_hz, drift_ppm, rng, latency_s=0.004, start_ms=0):
    """Device stamps at rate_hz; the host sees each after latency + exponential jitter."""
    errors = []
    for k in range(int(seconds * rate_hz)):
        true_host_s = 50.0 + k / rate_hz
        device_ms = (start_ms + int(round(k / rate_hz * 1e3 * (1 + drift_ppm * 1e-6)))) % (1 << 32)
        arrival_s = true_host_s + latency_s + rng.exponential(0.003)
        errors.append(mapper.map(device_ms, arrival_s) - true_host_s)
    return np.array(errors)


def test_clock_mapping_recovers_sample_times_despite_jitter_and_drift():
    rng = np.random.default_rng(3)
    errors = simulate(DeviceClockMapper(window_s=10.0), 600, 50, drift_ppm=-100, rng=rng)
    settled = errors[500:]
    # The minimum-delay estimate sits on the fixed 4 ms latency, not on the 3 ms mean jitter;
    # the 100 ppm drift moves the clocks 1 ms apart within the 10 s window.
    assert np.all(settled > 0.004 - 0.002) and np.all(settled < 0.004 + 0.0015)
    # Without a window the 100 ppm drift accumulates (60 ms over 600 s): the window matters.
    rng = np.random.default_rng(3)
    unwindowed = simulate(DeviceClockMapper(window_s=1e9), 600, 50, drift_ppm=-100, rng=rng)
    assert unwindowed[-1] < -0.05  # stamps fall behind: the slow device clock is never re-anchored


def test_clock_mapping_handles_wrap_and_restart_monotonically():
    mapper = DeviceClockMapper()
    near_wrap = (1 << 32) - 20
    times = [mapper.map(near_wrap, 10.0), mapper.map(near_wrap + 10, 10.01),
             mapper.map(5, 10.025)]
    assert np.diff(times) == pytest.approx([0.010, 0.015], abs=1e-9)
    mapper.map(60_000, 70.0)
    restarted = mapper.map(100, 70.1)  # the microcontroller rebooted: its clock starts over
    assert mapper.device_resets == 1 and restarted == pytest.approx(70.1)
    with pytest.raises(ValueError, match="outside"):
        mapper.map(-1, 13.0)
