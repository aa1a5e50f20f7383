#!/usr/bin/env python3
# make_seeds.py -- writes the seed inputs of fuzz_modbus and fuzz_can (tests/fuzz/corpus/), built
# byte by byte after the Modbus application protocol (MBAP + PDU) and struct can_frame, for the
# fixed ioconfig of each target.  Run it again after changing those configs.
import math
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))


def write(target, name, data):
    folder = os.path.join(HERE, "corpus", target)
    os.makedirs(folder, exist_ok=True)
    with open(os.path.join(folder, name), "wb") as f:
        f.write(data)


# ---- Modbus TCP: the answers to fuzz_modbus.cpp's requests, in its order -----------------------
def mbap(tid, unit, pdu):
    return struct.pack(">HHHB", tid, 0, len(pdu) + 1, unit) + pdu


def bits(values):
    out = bytearray((len(values) + 7) // 8)
    for i, v in enumerate(values):
        if v:
            out[i // 8] |= 1 << (i % 8)
    return bytes(out)


def read_bits(fc, values):
    b = bits(values)
    return bytes([fc, len(b)]) + b


def read_regs(fc, regs):
    return bytes([fc, 2 * len(regs)]) + b"".join(struct.pack(">H", r & 0xFFFF) for r in regs)


def f32_words(x, high_first=True):
    hi, lo = struct.unpack(">HH", struct.pack(">f", x))
    return [hi, lo] if high_first else [lo, hi]


def input_registers(status=0x0237, mode=-1, position=123456, velocity=1.5, step=7.0, cycles=40000):
    p = position & 0xFFFFFFFF
    return (
        [status, mode & 0xFFFF, p & 0xFFFF, p >> 16]
        + f32_words(velocity)
        + f32_words(step, False)
        + [cycles >> 16, cycles & 0xFFFF]
    )


def cycle(tid, first, inputs, error_id=-5, holding=(0, 0, 0), coils=(1,), discrete=(1, 0, 0, 0, 0, 1), powered=(1,)):
    """One dispatcher cycle's answers; returns (bytes, next tid)."""
    out = b""
    if first:  # the output blocks read once: coil 0, holding 0..2
        out += mbap(tid, 1, read_bits(1, coils))
        tid += 1
        out += mbap(tid, 1, read_regs(3, list(holding)))
        tid += 1
    out += mbap(tid, 1, read_bits(1, powered))
    tid += 1
    out += mbap(tid, 1, read_bits(2, discrete))
    tid += 1
    out += mbap(tid, 1, read_regs(4, inputs))
    tid += 1
    e = error_id & 0xFFFFFFFF
    out += mbap(tid, 2, read_regs(3, [e >> 16, e & 0xFFFF]))
    tid += 1
    out += mbap(tid, 1, struct.pack(">BHH", 15, 0, 1))
    tid += 1
    out += mbap(tid, 1, struct.pack(">BHH", 16, 0, 3))
    tid += 1
    return out, tid


def modbus_seeds():
    good, tid = cycle(1, True, input_registers())
    more, tid = cycle(
        tid, False, input_registers(position=-1, velocity=float("inf"), step=float("nan"), cycles=0xFFFFFFFF)
    )
    last, tid = cycle(tid, False, input_registers(status=0xFFFF, mode=-32768, velocity=-3.4e38, step=3.4e38))
    write("fuzz_modbus", "three-cycles", good + more + last)
    write("fuzz_modbus", "one-cycle", good)
    # An exception answer (illegal data address) to the input-register read, then the rest.
    exc, tid = cycle(1, True, input_registers())
    parts = exc.split(mbap(5, 1, read_regs(4, input_registers())))
    write("fuzz_modbus", "exception-answer", parts[0] + mbap(5, 1, bytes([0x84, 0x02])) + parts[1])
    # A device busy exception for the write, a wrong transaction id, a short answer.
    write("fuzz_modbus", "exception-busy", good[:-12] + mbap(8, 1, bytes([0x90, 0x06])))
    write("fuzz_modbus", "wrong-transaction-id", mbap(7, 1, read_bits(1, (1,))) + good[10:])
    write("fuzz_modbus", "truncated", good[:40])
    write("fuzz_modbus", "byte-count-too-long", mbap(1, 1, bytes([1, 200]) + bytes(200)))
    write("fuzz_modbus", "silent", b"")


# ---- CAN: records for fuzz_can.cpp (0xFF = a cycle, 16 = one struct can_frame follows) -----------
CAN_EFF, CAN_RTR, CAN_ERR = 0x80000000, 0x40000000, 0x20000000


def frame(can_id, data, dlc=None):
    dlc = len(data) if dlc is None else dlc
    return bytes([16]) + struct.pack("<IBBBB", can_id, dlc, 0, 0, 0) + bytes(data).ljust(8, b"\0")


def u64(v):
    return list(struct.pack("<Q", v & 0xFFFFFFFFFFFFFFFF))


def can_seeds():
    tpdo = frame(0x183, list(struct.pack("<Hi", 0x0237, -20000)))
    sig = frame(0x123, [0x51, 0xC4, 0xF9, 0xFF] + list(struct.pack("<f", 0.125)))
    ext = frame(0x1ABCDEF | CAN_EFF, u64(-123456789))
    top = frame(0x7FF, u64(0xF0FFFFFFFFFFFFFF))
    cycle = b"\xff"
    write("fuzz_can", "signals-and-pdo", tpdo + sig + ext + top + cycle + tpdo + cycle)
    write(
        "fuzz_can",
        "float-nan-inf",
        frame(0x123, [0, 0, 0, 0] + list(struct.pack("<f", math.inf)))
        + frame(0x1ABCDEF | CAN_EFF, [0] + list(struct.pack("<f", math.nan)) + [0, 0, 0])
        + cycle,
    )
    write("fuzz_can", "short-dlc", frame(0x123, [1, 2]) + frame(0x183, [0x37]) + cycle)
    write("fuzz_can", "dlc-above-8", frame(0x123, list(range(8)), dlc=15) + cycle)
    write("fuzz_can", "rtr-and-error-frames", frame(0x123 | CAN_RTR, [], dlc=8) + frame(CAN_ERR | 4, [0] * 8) + cycle)
    write("fuzz_can", "not-a-frame", bytes([3, 1, 2, 3]) + bytes([20]) + bytes(20) + tpdo)
    write("fuzz_can", "extended-id-as-standard", frame(0x1ABCDEF, u64(1)) + frame(0x123 | CAN_EFF, u64(1)) + cycle)


if __name__ == "__main__":
    modbus_seeds()
    can_seeds()
