"""OpenCV's own environment variables, checked before OpenCV is imported.

OpenCV reads some ``OPENCV_*`` variables as numbers or as yes/no, and a value it cannot parse
ends the process: at import (``OPENCV_BUFFER_AREA_ALWAYS_SAFE=x``, ``OPENCV_TRACE_MAX_CHILDREN=``:
an uncaught C++ exception, the process aborted with no word of which variable) or at the first
call that reads it (``OPENCV_FOR_THREADS_NUM=-1``: a ``cv2.error: stoull`` traceback). A
variable left over in a shell or a build server's settings broke every command.
:func:`check_opencv_environment` refuses such a value in one line naming the variable.

The names and their kinds were found by trying each ``OPENCV_*`` name the OpenCV library holds
with an unparsable value; the rules are OpenCV's own parsing (``getConfigurationParameterBool``
and ``getConfigurationParameterSizeT`` of ``modules/core/src/system.cpp``).
"""

from __future__ import annotations

import os
import re
from collections.abc import Mapping

from .errors import SpineMeshError

#: Variables OpenCV reads as yes/no: exactly one of :data:`OPENCV_BOOLEANS`.
BOOLEAN_VARIABLES = (
    "OPENCV_BUFFER_AREA_ALWAYS_SAFE", "OPENCV_DUMP_CONFIG", "OPENCV_DUMP_ERRORS", "OPENCV_ENABLE_MEMALIGN",
    "OPENCV_GAUSSIANBLUR_CHECK_BITEXACT_KERNELS", "OPENCV_OPENCL_CACHE_CLEANUP", "OPENCV_OPENCL_CACHE_ENABLE",
    "OPENCV_OPENCL_CACHE_LOCK_ENABLE", "OPENCV_OPENCL_CACHE_WRITE", "OPENCV_OPENCL_DISABLE_BUFFER_RECT_OPERATIONS",
    "OPENCV_OPENCL_ENABLE_MEM_USE_HOST_PTR", "OPENCV_OPENCL_PERF_CHECK_BYPASS",
    "OPENCV_OPENCL_VALIDATE_BINARY_PROGRAMS", "OPENCV_SKIP_CPU_BASELINE_CHECK", "OPENCV_TRACE",
    "OPENCV_TRACE_ITT_ENABLE", "OPENCV_TRACE_ITT_PARENT", "OPENCV_TRACE_ITT_SET_THREAD_NAME",
    "OPENCV_TRACE_SYNC_OPENCL", "OPENCV_VIDEOCAPTURE_DEBUG", "OPENCV_VIDEOIO_DEBUG", "OPENCV_VIDEOWRITER_DEBUG",
)

#: Variables OpenCV reads as a size: digits, optionally followed by a kilobyte or megabyte suffix.
SIZE_VARIABLES = (
    "OPENCV_FOR_THREADS_NUM", "OPENCV_IMGCODECS_AVIF_MAX_FILE_SIZE", "OPENCV_IMGCODECS_WEBP_MAX_FILE_SIZE",
    "OPENCV_IO_MAX_IMAGE_HEIGHT", "OPENCV_IO_MAX_IMAGE_PARAMS", "OPENCV_IO_MAX_IMAGE_PIXELS",
    "OPENCV_IO_MAX_IMAGE_WIDTH", "OPENCV_KMEANS_PARALLEL_GRANULARITY", "OPENCV_OPENCL_ALIGNMENT_MEM_USE_HOST_PTR",
    "OPENCV_THREAD_POOL_ACTIVE_WAIT_MAIN", "OPENCV_THREAD_POOL_ACTIVE_WAIT_PAUSE_LIMIT",
    "OPENCV_THREAD_POOL_ACTIVE_WAIT_THREADS_LIMIT", "OPENCV_THREAD_POOL_ACTIVE_WAIT_WORKER",
    "OPENCV_TRACE_DEPTH_OPENCV", "OPENCV_TRACE_MAX_CHILDREN", "OPENCV_TRACE_MAX_CHILDREN_OPENCV",
)

#: The yes/no values OpenCV takes (no spaces, no "on"/"yes").
OPENCV_BOOLEANS = ("0", "1", "false", "False", "FALSE", "true", "True", "TRUE")

#: A size as OpenCV takes it: digits, then nothing or KB/MB in one of three spellings.
_SIZE = re.compile(r"([0-9]+)(?:KB|Kb|kb|MB|Mb|mb)?")
#: OpenCV parses the digits as an unsigned 64-bit number; more ends the process too.
_LARGEST_SIZE = 2**64 - 1


def opencv_variable_problem(name: str, value: str) -> str | None:
    """What OpenCV reads variable ``name`` as, where it cannot read ``value`` so; None where it can.

    Parameters
    ----------
    name : str
        The variable's name (``OPENCV_FOR_THREADS_NUM``); a name not in :data:`BOOLEAN_VARIABLES`
        or :data:`SIZE_VARIABLES` is taken as OpenCV takes text (never refused).
    value : str
        Its value.

    Examples
    --------
    >>> opencv_variable_problem("OPENCV_FOR_THREADS_NUM", "4") is None
    True
    >>> opencv_variable_problem("OPENCV_TRACE", "on")
    'one of 0, 1, false, False, FALSE, true, True, TRUE'
    """
    if name in BOOLEAN_VARIABLES and value not in OPENCV_BOOLEANS:
        return f"one of {', '.join(OPENCV_BOOLEANS)}"
    if name in SIZE_VARIABLES:
        size = _SIZE.fullmatch(value)
        if size is None or int(size.group(1)) > _LARGEST_SIZE:
            return f"a whole number (at most {_LARGEST_SIZE}, optionally followed by KB or MB)"
    return None


def check_opencv_environment(environ: Mapping[str, str] | None = None) -> None:
    """Refuse, before OpenCV is imported, an ``OPENCV_*`` variable whose value OpenCV cannot parse.

    Parameters
    ----------
    environ : mapping, optional
        The environment to check (default: ``os.environ``).

    Raises
    ------
    SpineMeshError
        For the first such variable (by name), in one line naming it and saying to unset it.
    """
    environ = os.environ if environ is None else environ
    for name in sorted(n for n in environ if n.startswith("OPENCV_")):
        problem = opencv_variable_problem(name, environ[name])
        if problem is not None:
            raise SpineMeshError(f"environment variable {name}={environ[name]!r}: OpenCV reads it as {problem} "
                                 "and ends the run on any other value; unset it or give it one")
