"""``meshwm bench``: the paper's tables side by side with ours, mesh attacks, strength curves.

The paper is Tamane & Deshmukh, "Blind 3D model watermarking based on multi-resolution
representation and fuzzy logic".  Three parts (docs/bench.md explains every table and plot):

1. **Paper table.**  Each bundled model is marked at three strengths, matched to the PSNRs of
   the paper's Tables 2, 3 and 4 (92.45, 74.78 and 90.20 dB), and attacked with the paper's
   section 5 attacks (:data:`PAPER_ATTACKS`, the ``gim_*`` attacks of :mod:`meshwm.attacks.image`
   plus rotation, translation and scaling).  Each row holds the paper's correlation and PSNR
   (:data:`PAPER_TABLES`, copied from ``paper_tables.json``) next to ours, whether ours is at
   least the paper's, and for a row that is not: the PSNR our curve needs to reach the paper's
   figure (or the best it reaches).
2. **Curves.**  corr2 after each of the paper's attacks against the embedding PSNR, at the
   three matched strengths and more (:data:`CURVE_PSNRS`).
3. **Mesh attacks.**  Every mesh of a folder marked at the profile's default strength, the
   embedding's distortion (PSNR, MRMS, Hausdorff and RMS relative to the bounding-box
   diagonal), then BER, corr2 and verify's decision after each of :data:`MESH_ATTACKS`; rows
   marked ``required`` must reach corr2 >= 0.9 (issue #4).

The modules follow the data: :mod:`~meshwm.apps.bench.data` (the paper's tables, the rows and
their attacks), :mod:`~meshwm.apps.bench.scoring` (pure row builders),
:mod:`~meshwm.apps.bench.runner` (:func:`run_bench`: embed, attack, extract, score),
:mod:`~meshwm.apps.bench.report` (Markdown and JSON files) and :mod:`~meshwm.apps.bench.plots`
(the PNG figures).  Everything computes plain dicts and lists; :func:`write_outputs` turns them
into files.  Seeds and the key are fixed, so two runs give the same JSON except the ``seconds``
fields.
"""

from meshwm.apps.bench.data import (
    CURVE_ATTACKS,
    CURVE_PSNRS,
    KEY,
    MESH_ATTACKS,
    PAPER_ATTACKS,
    PAPER_MODELS,
    PAPER_TABLES,
    QUICK_MESH_ATTACKS,
    QUICK_PAPER_ATTACKS,
    Attack,
    apply_bench_attack,
    paper_psnr,
)
from meshwm.apps.bench.plots import curves_png, paper_marks_png
from meshwm.apps.bench.report import (
    BENCH_FILES,
    check_out,
    mesh_attacks_markdown,
    paper_table_markdown,
    write_outputs,
)
from meshwm.apps.bench.runner import bundled_models, meshes_in, packaged_spot, run_bench
from meshwm.apps.bench.scoring import (
    attacked_psnr,
    judge_paper_rows,
    mark_from_hex,
    match_step,
    psnr_needed,
    score_extraction,
    summarise_mesh_attacks,
    summarise_paper,
)
from meshwm.apps.progress import ProgressBar

__all__ = [
    "BENCH_FILES",
    "CURVE_ATTACKS",
    "CURVE_PSNRS",
    "KEY",
    "MESH_ATTACKS",
    "PAPER_ATTACKS",
    "PAPER_MODELS",
    "PAPER_TABLES",
    "QUICK_MESH_ATTACKS",
    "QUICK_PAPER_ATTACKS",
    "Attack",
    "ProgressBar",
    "apply_bench_attack",
    "attacked_psnr",
    "bundled_models",
    "check_out",
    "curves_png",
    "judge_paper_rows",
    "mark_from_hex",
    "match_step",
    "mesh_attacks_markdown",
    "meshes_in",
    "packaged_spot",
    "paper_marks_png",
    "paper_psnr",
    "paper_table_markdown",
    "psnr_needed",
    "run_bench",
    "score_extraction",
    "summarise_mesh_attacks",
    "summarise_paper",
    "write_outputs",
]
