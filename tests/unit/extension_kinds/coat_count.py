"""A benchmark: how many coats each suite stack has, and how many of them scatter. One ``Bench``
(its name after ``lamella bench``, one line of description, its run and its own options) and one
``register`` make it a subcommand; its page goes through ``write_page``."""
from lamella_dev import suite
from lamella_dev.bench import Bench, cases_argument, write_page
from lamella_dev.bench import register as register_bench
from lamella_dev.bench import unregister as unregister_bench


def run(out_dir, args):
    rows = {}
    for name in args.cases or suite.names():
        stack = suite.load(name)
        rows[name] = {"coats": len(stack.coats), "scattering": sum(max(c.sigma_s) > 0 for c in stack.coats)}
    lines = ["# Coats per suite stack", "", "`lamella bench coat-count`: how many coats each stack has, and how many "
             "of them scatter.", "", "| stack | coats | scattering |", "|---|---:|---:|"]
    lines += [f"| {name} | {r['coats']} | {r['scattering']} |" for name, r in rows.items()]
    return write_page(out_dir, "coat_count", "\n".join(lines), {"stacks": rows})


BENCH = Bench("coat-count", "how many coats each suite stack has, and how many scatter", run, cases_argument)


def register():
    register_bench(BENCH)


def unregister():
    unregister_bench(BENCH)
