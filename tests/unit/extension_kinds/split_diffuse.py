"""A model that emits the extension's lobe kind (``translucent``): yamaguchi2019, with half of
the light a Lambertian base sends up leaving through the surface instead (a thin diffuser)."""
from lamella.core import models
from lamella.core.models import MODELS
from lamella.core.models.types import Lobe

NAME = "split_diffuse"


class SplitDiffuse:
    name = NAME

    def run(self, ops, stack, wi):
        out = []
        for lobe in MODELS["yamaguchi2019"].run(ops, stack, wi):
            if lobe.kind == "diffuse":
                half = lobe.weight * 0.5
                out += [Lobe(half, 0.0, 0.0, 0.0, "diffuse"), Lobe(half, 0.0, 0.0, 0.0, "translucent")]
            else:
                out.append(lobe)
        return out


MODEL = SplitDiffuse()


def register():
    models.register(MODEL)


def unregister():
    models.unregister(MODEL)
