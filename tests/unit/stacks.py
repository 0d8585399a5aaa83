"""Stacks used across the unit tests (the accuracy suite lives in lamella_dev.suite)."""
GOLD = {"type": "conductor", "eta": [0.143, 0.374, 1.442], "k": [3.983, 2.385, 1.603]}


def gold(roughness=0.0, rotation=0.0):
    return dict(GOLD, roughness=roughness, rotation=rotation)


def coat(ior=1.5, roughness=0.0, rotation=0.0, thickness=0.0, sigma_a=(0.0, 0.0, 0.0)):
    return {"type": "coat", "ior": ior, "roughness": roughness, "rotation": rotation,
            "thickness": thickness, "sigma_a": list(sigma_a)}


def stack(*coats, base=None):
    return {"name": "t", "layers": list(coats), "base": base if base is not None else gold()}
