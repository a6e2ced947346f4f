"""Imported first by the sweep workers' fork server (`pool.PRELOAD`): the modules every worker
needs, loaded once for all of them with the garbage collector off (it would walk their new
objects again and again while they load), then frozen, so that no worker's collection walks
them again (nor writes to their pages, which the workers share with the server); and numpy with
one OpenBLAS thread (`pool.one_blas_thread`)."""

import gc
import warnings

from .pool import one_blas_thread

# `python -m pylmp_lattice.cli sweep ...`: multiprocessing runs the command's module again in each
# worker as its __mp_main__ (runpy), which warns that the server preloaded it already (harmless:
# the module defines, its main() is guarded). The filter is the server's, so its workers' too.
warnings.filterwarnings("ignore", message=r"'pylmp_lattice\.cli' found in sys\.modules", category=RuntimeWarning)

with one_blas_thread():
    gc.disable()
    try:
        from .. import engine, summary  # noqa: F401
        from ..run_folder import execution, folder  # noqa: F401
        from . import batch  # noqa: F401
    finally:
        gc.freeze()
        gc.enable()
