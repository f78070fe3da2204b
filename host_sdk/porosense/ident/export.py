"""A C header of the float coefficients of an EstimatorStructure (for embedding elsewhere)."""

from __future__ import annotations

import re

import numpy as np


def _arr(name: str, values) -> str:
    vals = ", ".join(f"{float(v)!r}f" if np.isfinite(v) else "0.0f" for v in np.ravel(values))
    return f"static const float {name}[{len(np.ravel(values))}] = {{{vals}}};"


def c_header(structure, name: str = "porosense_model") -> str:
    """Header text: per output, per branch the PWL breakpoints and SOS rows (b0 b1 b2 1 a1 a2)."""
    ident = re.sub(r"\W", "_", name)
    guard = ident.upper() + "_H"
    lines = [
        f"/* {name}: float coefficients of a porosense estimator. */",
        "/* y_j = offset_j + H2_j(g_j(sum_i H1_ij(f_ij(u_i[k - delay_ij] - u_offset_ij)))) */",
        f"#ifndef {guard}",
        f"#define {guard}",
        "",
        f"#define {ident.upper()}_TS {structure.ts!r}f",
        f"#define {ident.upper()}_N_INPUTS {len(structure.inputs)}",
        f"#define {ident.upper()}_N_OUTPUTS {len(structure.outputs)}",
        "",
    ]
    for j, out in enumerate(structure.outputs):
        p = f"{ident}_out{j}"
        lines.append(f"/* output {j}: {out.name} ({out.kind}) */")
        lines.append(f"static const float {p}_offset = {out.offset!r}f;")
        for br in out.branches:
            q = f"{p}_in{br.input}"
            lines.append(f"static const int {q}_delay = {br.delay};")
            lines.append(f"static const float {q}_u_offset = {br.u_offset!r}f;")
            if br.f is not None:
                lines += [_arr(f"{q}_f_x", br.f.x), _arr(f"{q}_f_y", br.f.y)]
            lines.append(f"#define {q.upper()}_H1_SECTIONS {br.h1.n_sections}")
            lines.append(_arr(f"{q}_h1_sos", br.h1.sos))
        if out.g is not None:
            lines += [_arr(f"{p}_g_x", out.g.x), _arr(f"{p}_g_y", out.g.y)]
        if out.h2 is not None:
            lines.append(f"#define {p.upper()}_H2_SECTIONS {out.h2.n_sections}")
            lines.append(_arr(f"{p}_h2_sos", out.h2.sos))
        lines.append("")
    lines += [f"#endif /* {guard} */", ""]
    return "\n".join(lines)
