"""Count the instructions one call of a function executes, by single-stepping
it under gdb: the bank's step (`counted_bank_step` of
`benches/counted_steps.rs`), one compensator's (`counted_step_f64`,
`counted_step_f32`) or the C bank's (`bank_step` of `bank steps`).
Vector instructions (those naming an xmm, ymm or zmm register) are counted
apart from the rest (addresses, bounds checks, loop counts, spills).

  gdb -q -batch -x benches/peers/count_instructions.py \\
      --args target/release/deps/counted_steps-HASH bank 64
  COUNT_FUNCTION=counted_step_f64 gdb -q -batch -x benches/peers/count_instructions.py \\
      --args target/release/deps/counted_steps-HASH f64
  COUNT_FUNCTION=bank_step gdb -q -batch -x benches/peers/count_instructions.py \\
      --args target/peers/bank steps 64

COUNT_FUNCTION names the function (default counted_bank_step), COUNT_SKIP
how many calls run first (default 100: a warm, steady state). Per block of
eight channels: the difference of the counts at 128 and 8 channels, over 15.
"""

import os

import gdb

function = os.environ.get("COUNT_FUNCTION", "counted_bank_step")
skip = int(os.environ.get("COUNT_SKIP", "100"))

gdb.execute("set pagination off")
gdb.execute("set confirm off")
gdb.execute("break main")
gdb.execute("run")
gdb.execute(f"break *{function}")
for _ in range(skip + 1):
    gdb.execute("continue", to_string=True)

# one call: from its first instruction until it returns to its caller
sp = int(gdb.parse_and_eval("$sp"))
ret = int(gdb.parse_and_eval("*(unsigned long *)$sp"))
counts = {}
while True:
    pc = int(gdb.parse_and_eval("$pc"))
    if pc == ret and int(gdb.parse_and_eval("$sp")) > sp:
        break
    counts[pc] = counts.get(pc, 0) + 1
    gdb.execute("stepi", to_string=True)

total = vector = 0
for pc, n in counts.items():
    text = gdb.execute(f"x/i {pc}", to_string=True)
    total += n
    if "mm" in text.split(":", 1)[1]:
        vector += n
print(f"{function}: {total} instructions, {vector} vector, {total - vector} other")
gdb.execute("kill")
