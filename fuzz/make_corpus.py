#!/usr/bin/env python3
"""Builds the smoke corpus fuzz/corpus/<reader>/ from the seeds in fuzz/seeds/<reader>/.

Deterministic (the same seeds give the same files): each seed is copied, then mutated N times
with byte-level mutations (bit flips, interesting bytes, deletions, duplications, truncations,
splices of two seeds) and format-aware ones (a number of the text replaced by an extreme value
such as 1e308, 1e154, 5e-324, nan; a MessagePack float64 payload replaced the same way; a
MessagePack length made huge). The seeds are written by the project's own commands
(fuzz/make_seeds.sh). Usage: python3 fuzz/make_corpus.py [--per-seed N]
"""
import argparse
import os
import random
import re
import shutil
import struct

HERE = os.path.dirname(os.path.abspath(__file__))
INTERESTING_NUMBERS = [
    "1e308", "-1e308", "1e154", "-1e154", "1.8e308", "5e-324", "-5e-324", "1e-320", "6e21",
    "1.4e19", "-1.4e7", "1e300", "nan", "inf", "-inf", "-0", "0", "-1", "4294967296",
    "18446744073709551615", "18446744073709551616", "9223372036854775807", "99999999999",
    "100000", "1", "0.5", "1e9", "2147483648", "-2147483649", "1e", "0x10", "",
]
INTERESTING_DOUBLES = [1e308, -1e308, 1e154, -1e154, 5e-324, 6e21, 1.4e19, -1.4e7, 1e300,
                       float("nan"), float("inf"), float("-inf"), -0.0, 0.0, 1e9, 4294967296.0]
INTERESTING_BYTES = [0x00, 0xff, 0x7f, 0x80, 0xc1, 0xcb, 0xdd, 0xdf, ord("{"), ord("["),
                     ord('"'), ord("\n"), ord(" "), ord(","), ord(":")]
NUMBER = re.compile(rb"-?\d+(\.\d+)?([eE][-+]?\d+)?")


def flip_bits(data, rng):
    data = bytearray(data)
    for _ in range(rng.randint(1, 4)):
        i = rng.randrange(len(data))
        data[i] ^= 1 << rng.randrange(8)
    return bytes(data)


def interesting_byte(data, rng):
    data = bytearray(data)
    data[rng.randrange(len(data))] = rng.choice(INTERESTING_BYTES)
    return bytes(data)


def delete_range(data, rng):
    i = rng.randrange(len(data))
    return data[:i] + data[i + rng.randint(1, max(1, len(data) // 8)):]


def duplicate_range(data, rng):
    i = rng.randrange(len(data))
    j = min(len(data), i + rng.randint(1, 64))
    return data[:j] + data[i:j] * rng.randint(1, 8) + data[j:]


def truncate(data, rng):
    return data[:rng.randrange(len(data))]


def replace_number(data, rng):
    numbers = list(NUMBER.finditer(data))
    if not numbers:
        return flip_bits(data, rng)
    for _ in range(rng.randint(1, 2)):
        m = rng.choice(numbers)
        data = data[:m.start()] + rng.choice(INTERESTING_NUMBERS).encode() + data[m.end():]
        numbers = list(NUMBER.finditer(data))
        if not numbers:
            break
    return data


def replace_msgpack_double(data, rng):
    places = [i for i in range(len(data) - 8) if data[i] == 0xcb]
    if not places:
        return replace_msgpack_length(data, rng)
    i = rng.choice(places)
    return data[:i + 1] + struct.pack(">d", rng.choice(INTERESTING_DOUBLES)) + data[i + 9:]


def replace_msgpack_length(data, rng):
    # array16/32, map16/32, str8/16/32, bin8/16/32: make the declared length absurd.
    places = [i for i in range(len(data) - 4)
              if data[i] in (0xdc, 0xdd, 0xde, 0xdf, 0xd9, 0xda, 0xdb, 0xc4, 0xc5, 0xc6)]
    if not places:
        return flip_bits(data, rng)
    i = rng.choice(places)
    width = {0xdc: 2, 0xde: 2, 0xda: 2, 0xc5: 2, 0xd9: 1, 0xc4: 1}.get(data[i], 4)
    return data[:i + 1] + b"\xff" * width + data[i + 1 + width:]


def splice(data, other, rng):
    return data[:rng.randrange(len(data))] + other[rng.randrange(len(other)):]


def mutate(data, seeds, rng):
    is_msgpack = data[:1] and (data[0] & 0xf0 == 0x80 or data[0] in (0xde, 0xdf))
    text_ops = [replace_number] * 4
    pack_ops = [replace_msgpack_double] * 3 + [replace_msgpack_length] * 2
    ops = [flip_bits, interesting_byte, delete_range, duplicate_range, truncate]
    ops += pack_ops if is_msgpack else text_ops
    op = rng.choice(ops + ["splice"])
    if op == "splice":
        return splice(data, rng.choice(seeds), rng)
    return op(data, rng)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--per-seed", type=int, default=12)
    parser.add_argument("--map-per-seed", type=int, default=40)
    parser.add_argument("--only", help="one reader (a folder of the seeds)")
    parser.add_argument("--seeds", default=os.path.join(HERE, "seeds"))
    parser.add_argument("--out", default=os.path.join(HERE, "corpus"))
    args = parser.parse_args()
    total = 0
    for reader in sorted(os.listdir(args.seeds)):
        if args.only and reader != args.only:
            continue
        seed_dir = os.path.join(args.seeds, reader)
        names = sorted(os.listdir(seed_dir))
        seeds = [open(os.path.join(seed_dir, n), "rb").read() for n in names]
        out_dir = os.path.join(args.out, reader)
        shutil.rmtree(out_dir, ignore_errors=True)
        os.makedirs(out_dir)
        # Maps are the main untrusted input (four seeds): more mutations each.
        per_seed = (args.map_per_seed if reader == "map" else
                    max(args.per_seed, 60 // max(1, len(seeds))))
        for name, data in zip(names, seeds):
            rng = random.Random(f"{reader}/{name}")
            open(os.path.join(out_dir, f"seed-{name}"), "wb").write(data)
            for k in range(per_seed):
                mutated = data
                for _ in range(rng.randint(1, 3)):
                    mutated = mutate(mutated, seeds, rng) if mutated else b"\x00"
                open(os.path.join(out_dir, f"{name}-{k:03d}"), "wb").write(mutated)
        count = len(os.listdir(out_dir))
        total += count
        print(f"{reader}: {len(seeds)} seeds, {count} files")
    print(f"total: {total} files")


if __name__ == "__main__":
    main()
