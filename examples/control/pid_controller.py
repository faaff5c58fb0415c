"""The built-in PID, rewritten in Python, as a benchmark-control program:
mfcbeam benchmark-control --exec 'python3 examples/control/pid_controller.py'
In: k,t,reference,measurement per line; out: the correction (V), flushed."""
import os
import sys

TS = float(os.environ.get("MFCBEAM_SAMPLE_TIME", "0.0002"))
# poles of the first mode placed at (s + w1)(s^2 + 1.4 w1 s + w1^2), T_f = T_d/2
KP, KI, KD, TF = 179703.92370092354, 9830276.72724188, 3971.609828392829, 0.011050426019085353

integral = derivative = 0.0
last = None
for line in sys.stdin:
    k, t, reference, measurement = map(float, line.split(","))
    e = measurement - reference
    last = e if last is None else last
    integral += TS * e
    derivative = (TF * derivative + KD * (e - last)) / (TF + TS)
    last = e
    print(repr(-(KP * e + KI * integral + derivative)), flush=True)
