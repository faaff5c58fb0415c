"""A small Prandtl-Ishlinskii library written the way published PI code
usually is, with its own conventions: a backlash "play" is described by its
dead-band WIDTH (the band is [y - width/2, y + width/2], so width = 2 r in
mfcbeam's terms) and by its initial OUTPUT, and the operator is H alone (no
creep). It knows nothing of mfcbeam; `adapter.py` translates conventions.

Python standard library only.
"""


class Backlash:
    """One play: output y follows the input u within a dead band of `width`."""

    def __init__(self, width, initial_output=0.0):
        self.width = width
        self.y = initial_output

    def update(self, u):
        half = 0.5 * self.width
        self.y = max(u - half, min(u + half, self.y))
        return self.y


class PIOperator:
    """y = sum_i weight_i * backlash_i(u)."""

    def __init__(self, widths, weights, initial_outputs=None):
        outputs = initial_outputs or [0.0] * len(widths)
        self.plays = [Backlash(d, y0) for d, y0 in zip(widths, outputs)]
        self.weights = list(weights)

    def update(self, u):
        return sum(w * p.update(u) for w, p in zip(self.weights, self.plays))

    def inverse(self):
        """The inverse PI operator (Kuhnen's rules), in the same conventions:
        band widths of the inverse plays, their weights, their initial
        outputs matched to this operator's."""
        n = len(self.weights)
        half = [0.5 * p.width for p in self.plays]
        slope = [sum(self.weights[: j + 1]) for j in range(n)]
        widths = [
            2.0 * sum(self.weights[i] * (half[j] - half[i]) for i in range(j + 1))
            for j in range(n)
        ]
        weights = [1.0 / self.weights[0]] + [
            -self.weights[j] / (slope[j] * slope[j - 1]) for j in range(1, n)
        ]
        y = [p.y for p in self.plays]
        outputs = [
            slope[j] * y[j] + sum(self.weights[i] * y[i] for i in range(j + 1, n))
            for j in range(n)
        ]
        return PIOperator(widths, weights, outputs)
