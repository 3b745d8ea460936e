"""VIS/TIR image fusion for spacecraft navigation: the flight core, the metrics and the
renderer of the `fusion` project, with numpy arrays. Results are the `fusion` CLI's, bit for bit.

The functions are the compiled extension's (`vistir._vistir`); `vistir.campaign` runs Monte
Carlo campaigns of the navigation judge on Dask (`pip install './python[campaign]'`).
"""

from ._vistir import *  # noqa: F401,F403  (fuse, Sequence, rescale, … : the extension's API)
from ._vistir import __version__  # noqa: F401
