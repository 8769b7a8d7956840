"""The text the commands print for runs: the line naming their scheme and the table of
their records (``timpm run``, ``timpm convergence``)."""

__all__ = ["scheme_line", "run_table"]


def scheme_line(record) -> str:
    """The line above a table: the scheme the runs used (defaults depend on the problem
    and the basis, e.g. mms-1d and mms-2d)."""
    return (f"{record['problem']}: {record['basis']} basis, {record['mass']} mass, "
            f"{record['projection']} projection, {record['transfer']} transfer, "
            f"{record['integrator']}, {record['placement']} placement")


def run_table(records, rates=None):
    """The runs' records as the table the commands print: per mesh the errors, the ratio
    and observed rate against the mesh before (``rates``), the grid crossings, the steps,
    the stepping and compilation seconds."""
    l2 = " " + f"{'e_L2':>12}" if "l2_error" in records[0] else ""
    head = (f"{'elements':>8} {'ppc':>4} {'e_RMS':>12}{l2} {'ratio':>7} {'log2':>6} "
            f"{'crossings':>9} {'steps':>7} {'wall [s]':>9} {'compile [s]':>11}")
    lines = [head]
    for i, r in enumerate(records):
        ratio = log2 = ""
        if rates and i > 0:
            ratio, log2 = f"{rates[i - 1]['ratio']:7.3f}", f"{rates[i - 1]['rate']:6.3f}"
        err = f"{r['rms_error']:12.4e}" if r["rms_error"] is not None else f"{'-':>12}"
        if "l2_error" in r:
            err += f" {r['l2_error']:12.4e}"
        lines.append(f"{r['elements']:>8} {r['ppc']:>4} {err} {ratio:>7} {log2:>6} "
                     f"{_or_dash(r['grid_crossings']):>9} {r['steps']:>7} {r['wall_seconds']:9.3f} "
                     f"{r['compile_seconds']:11.3f}")
    return "\n".join(lines)


def _or_dash(value):
    return "-" if value is None else value
