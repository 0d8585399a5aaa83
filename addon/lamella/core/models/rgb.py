"""RGB triples over any backend's scalar type (numpy arrays, traced expressions, plain floats).

Model code is written per colour channel only through this type, so a backend sees three scalar
streams and never needs a vector type of its own.
"""
from __future__ import annotations


class RGB:
    __slots__ = ("r", "g", "b")

    def __init__(self, r, g, b):
        self.r, self.g, self.b = r, g, b

    @classmethod
    def splat(cls, x) -> "RGB":
        return cls(x, x, x)

    def __iter__(self):
        return iter((self.r, self.g, self.b))

    def map(self, fn) -> "RGB":
        return RGB(fn(self.r), fn(self.g), fn(self.b))

    def zip(self, other, fn) -> "RGB":
        o = other if isinstance(other, RGB) else RGB.splat(other)
        return RGB(fn(self.r, o.r), fn(self.g, o.g), fn(self.b, o.b))

    def average(self):
        return (self.r + self.g + self.b) * (1.0 / 3.0)

    def __add__(self, o):
        return self.zip(o, lambda a, b: a + b)

    __radd__ = __add__

    def __sub__(self, o):
        return self.zip(o, lambda a, b: a - b)

    def __rsub__(self, o):
        return self.zip(o, lambda a, b: b - a)

    def __mul__(self, o):
        return self.zip(o, lambda a, b: a * b)

    __rmul__ = __mul__

    def __truediv__(self, o):
        return self.zip(o, lambda a, b: a / b)

    def __rtruediv__(self, o):
        return self.zip(o, lambda a, b: b / a)

    def __neg__(self):
        return self.map(lambda a: -a)

    def __repr__(self):
        return f"RGB({self.r!r}, {self.g!r}, {self.b!r})"
