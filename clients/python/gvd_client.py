"""A Python client for gvd-server (docs/API.md). Standard library only.

    from gvd_client import Client
    client = Client("http://127.0.0.1:8080")
    job = client.submit("tests/data/scenes/gears2d.json")
    job.wait(progress=lambda stage, fraction: print(stage, fraction))
    print(job.neighbors("gear_a", ring=1))
    open("gvd.glb", "wb").write(job.glb())

Every error answer of the server (an RFC 9457 problem document) is raised as the exception
class of its problem type (``InvalidScene``, ``NoPath``, ``ServerBusy``...), all subclasses
of ``GvdError``. Requests refused with 503 are retried with exponential backoff, honouring
``Retry-After``; connection failures are retried for requests that are safe to repeat.
"""

from __future__ import annotations

import http.client
import json
import os
import socket
import threading
import time
import urllib.parse
import uuid
from typing import Any, Callable, Iterable, Optional, Sequence, Union

__all__ = [
    "Client", "Job", "GvdError", "GvdConnectionError", "InvalidScene", "InvalidArgument",
    "UnsupportedFormat", "OutsideDomain", "LimitExceeded", "NotFound", "StorageError",
    "JobCancelled", "InternalServerError", "RouteNotFound", "MethodNotAllowed",
    "LengthRequired", "BodyTooLarge", "HeadersTooLarge", "UnsupportedMediaType",
    "UnsupportedEncoding", "ServerBusy", "QueueFull", "Draining", "TooManyStreams",
    "RateLimited", "QueueUnavailable", "Overloaded", "UriTooLong", "RequestTimeout",
    "JobNotFinished", "JobFailed", "NoPath", "WaitTimeout", "PROBLEM_TYPES",
]


# --------------------------------------------------------------------------------- errors

class GvdError(Exception):
    """An error answer of the server. ``status`` is the HTTP status, ``type`` the problem
    type (``/problems/...``), ``detail`` the human explanation and ``problem`` the whole
    problem document (``object``/``element`` say where in a bad scene)."""

    def __init__(self, problem: dict, status: Optional[int] = None):
        self.problem = dict(problem)
        self.status = status if status is not None else problem.get("status")
        self.type = problem.get("type", "about:blank")
        self.title = problem.get("title", "")
        self.detail = problem.get("detail", "")
        super().__init__(f"{self.status} {self.title or self.type}: {self.detail}")


class GvdConnectionError(GvdError):
    """The server could not be reached (refused, reset, timed out) after the retries."""

    def __init__(self, detail: str):
        super().__init__({"type": "network-error", "title": "Network error", "detail": detail},
                         status=None)


class WaitTimeout(GvdError):
    """``Job.wait(timeout=...)`` ran out of time; the job keeps running on the server."""

    def __init__(self, detail: str):
        super().__init__({"type": "wait-timeout", "title": "Wait timed out", "detail": detail},
                         status=None)


class InvalidScene(GvdError):
    """422: malformed geometry; ``problem['object']``/``['element']`` say where."""


class InvalidArgument(GvdError):
    """400: a bad parameter, query or JSON body."""


class UnsupportedFormat(GvdError):
    """415: the body is not a scene format."""


class OutsideDomain(GvdError):
    """422: a query point outside the domain box."""


class LimitExceeded(GvdError):
    """422: too many objects/simplices, or the job hit a leaf, time or memory limit."""


class NotFound(GvdError):
    """404: unknown job or label."""


class StorageError(GvdError):
    """500: the server's store cannot be written."""


class JobCancelled(GvdError):
    """409: the job was cancelled."""


class InternalServerError(GvdError):
    """500: a bug in the server (``problem['request_id']`` finds it in the log)."""


class RouteNotFound(GvdError):
    """404: no such route (a client/server version mismatch)."""


class MethodNotAllowed(GvdError):
    """405."""


class LengthRequired(GvdError):
    """411."""


class BodyTooLarge(GvdError):
    """413: the scene is over the server's --max-body."""


class HeadersTooLarge(GvdError):
    """431: over --max-headers / --max-header-bytes, or a header line over 8 KiB."""


class UriTooLong(GvdError):
    """414: a request line over 8 KiB (send long point lists in a POST body)."""


class RequestTimeout(GvdError):
    """408: the request headers took longer than the server's --header-timeout, or its body
    longer than --body-seconds + Content-Length / --min-body-rate."""


class UnsupportedMediaType(GvdError):
    """415: a Content-Type that is not a scene."""


class UnsupportedEncoding(GvdError):
    """415: compressed request bodies are not accepted."""


class ServerBusy(GvdError):
    """503 after the retries; ``retry_after`` (seconds) says when to come back."""

    def __init__(self, problem: dict, status: Optional[int] = None,
                 retry_after: Optional[float] = None):
        super().__init__(problem, status)
        self.retry_after = retry_after


class QueueFull(ServerBusy):
    """503: the job queue is full."""


class Draining(ServerBusy):
    """503: the server is shutting down."""


class TooManyStreams(ServerBusy):
    """503: too many event streams open (``Job.wait`` falls back to polling)."""


class RateLimited(ServerBusy):
    """429: this client is over its submission rate; ``retry_after`` says when a token is back."""


class QueueUnavailable(ServerBusy):
    """503: the server cannot reach its shared job queue (Redis); it reconnects by itself."""


class Overloaded(ServerBusy):
    """503: every HTTP thread is busy and --max-queued-requests requests wait for one."""


class JobNotFinished(GvdError):
    """409: outputs or queries of a job still queued or running."""


class JobFailed(GvdError):
    """409: outputs or queries of a failed job."""


class AdaptiveOnly(GvdError):
    """409: an output or query of a grid job (``mode=grid``) that needs the adaptive result
    (GVD surface, result file, neighbours, nearest, paths, explode, tight, contacts)."""


class NoPath(GvdError):
    """422: no path joins the points; ``path`` is the path document (empty ``points``,
    ``reason``)."""

    @property
    def path(self) -> dict:
        return self.problem.get("path", {})


#: problem type -> exception class: one class per row of the table in docs/API.md.
PROBLEM_TYPES = {
    "/problems/invalid-scene": InvalidScene,
    "/problems/invalid-argument": InvalidArgument,
    "/problems/unsupported-format": UnsupportedFormat,
    "/problems/outside-domain": OutsideDomain,
    "/problems/limit-exceeded": LimitExceeded,
    "/problems/not-found": NotFound,
    "/problems/io-error": StorageError,
    "/problems/cancelled": JobCancelled,
    "/problems/internal": InternalServerError,
    "/problems/route-not-found": RouteNotFound,
    "/problems/method-not-allowed": MethodNotAllowed,
    "/problems/length-required": LengthRequired,
    "/problems/body-too-large": BodyTooLarge,
    "/problems/headers-too-large": HeadersTooLarge,
    "/problems/unsupported-media-type": UnsupportedMediaType,
    "/problems/unsupported-encoding": UnsupportedEncoding,
    "/problems/queue-full": QueueFull,
    "/problems/draining": Draining,
    "/problems/too-many-streams": TooManyStreams,
    "/problems/job-not-finished": JobNotFinished,
    "/problems/job-failed": JobFailed,
    "/problems/no-path": NoPath,
    "/problems/rate-limited": RateLimited,
    "/problems/queue-unavailable": QueueUnavailable,
    "/problems/uri-too-long": UriTooLong,
    "/problems/request-timeout": RequestTimeout,
    "/problems/overloaded": Overloaded,
    "/problems/adaptive-only": AdaptiveOnly,
}


def error_from_problem(problem: dict, status: Optional[int] = None,
                       retry_after: Optional[float] = None) -> GvdError:
    """The exception for a problem document (unknown types: by status class)."""
    cls = PROBLEM_TYPES.get(problem.get("type", ""))
    status = status if status is not None else problem.get("status")
    if cls is None:
        cls = {404: NotFound, 429: ServerBusy, 503: ServerBusy}.get(status, GvdError)
    if issubclass(cls, ServerBusy):
        return cls(problem, status, retry_after)
    return cls(problem, status)


# ------------------------------------------------------------------------------ transport

_CONTENT_TYPES = {
    ".json": "application/json", ".obj": "model/obj", ".glb": "model/gltf-binary",
    ".gltf": "model/gltf+json", ".stl": "model/stl", ".ply": "model/x-ply",
    ".off": "application/octet-stream", ".npy": "application/x-npy",
}
_PARAMS = ("max_depth", "contact_depth", "ambiguity_levels", "ambiguity_rounds",
           "unseen_rounds", "domain", "frame", "refine", "junctions", "resolution", "curved_tolerance",
           "mode", "metric", "float64", "unsigned", "range_cells", "spacing", "background",
           "units")


class _Response:
    def __init__(self, status: int, headers: dict, body: bytes):
        self.status, self.headers, self.body = status, headers, body

    def json(self) -> Any:
        return json.loads(self.body.decode("utf-8"))


def _retry_after(value: Optional[str]) -> Optional[float]:
    if not value:
        return None
    try:
        return max(0.0, float(value))
    except ValueError:
        return None  # an HTTP date: gvd-server never sends one


class Client:
    """A gvd-server at ``url`` (``http://host:port``).

    Thread-safe: each thread uses its own kept-alive connection.

    ``timeout``: seconds for connecting and for each read. ``retries``: how many times a
    request refused with 503 (queue full, draining) or failing to connect is tried again;
    the wait doubles from ``backoff`` seconds (at most ``max_backoff``) unless the server's
    ``Retry-After`` says otherwise.
    """

    def __init__(self, url: str = "http://127.0.0.1:8080", timeout: float = 30.0,
                 retries: int = 4, backoff: float = 0.5, max_backoff: float = 30.0):
        parts = urllib.parse.urlsplit(url if "://" in url else "http://" + url)
        if parts.scheme not in ("http", "https"):
            raise ValueError(f"unsupported URL scheme {parts.scheme!r} in {url!r}")
        self.url = f"{parts.scheme}://{parts.netloc}"
        self._scheme, self._host, self._port = parts.scheme, parts.hostname, parts.port
        self._prefix = parts.path.rstrip("/")
        self.timeout, self.retries = timeout, retries
        self.backoff, self.max_backoff = backoff, max_backoff
        # One kept-alive connection per thread: a Client may be shared by threads
        # (http.client connections may not).
        self._local = threading.local()

    @property
    def _conn(self) -> Optional[http.client.HTTPConnection]:
        return getattr(self._local, "conn", None)

    @_conn.setter
    def _conn(self, conn: Optional[http.client.HTTPConnection]) -> None:
        self._local.conn = conn

    # -- low level

    def _connect(self, timeout: Optional[float] = None) -> http.client.HTTPConnection:
        cls = http.client.HTTPSConnection if self._scheme == "https" else http.client.HTTPConnection
        return cls(self._host, self._port, timeout=timeout or self.timeout)

    def _delay(self, attempt: int, retry_after: Optional[float]) -> float:
        if retry_after is not None:
            return retry_after
        return min(self.max_backoff, self.backoff * (2 ** attempt))

    def request(self, method: str, path: str, body: Optional[bytes] = None,
                headers: Optional[dict] = None, idempotent: bool = True,
                expect: Sequence[int] = (200,)) -> _Response:
        """One API request with the retries; raises the problem's exception for any status
        outside ``expect``. ``idempotent``: may be sent again after a connection failed
        mid-request (a refused connection is always retried: nothing was sent)."""
        headers = dict(headers or {})
        headers.setdefault("Accept", "application/json, application/problem+json, */*")
        if body is not None:
            headers["Content-Length"] = str(len(body))
        attempt = 0
        while True:
            try:
                if self._conn is None:
                    self._conn = self._connect()
                try:
                    self._conn.request(method, self._prefix + path, body=body, headers=headers)
                except (BrokenPipeError, ConnectionResetError):
                    # The server may refuse a body before reading it (413 over --max-body) and
                    # close the connection: its answer is still there to read.
                    if body is None or len(body) < 65536:
                        raise
                    try:
                        raw = self._conn.getresponse()
                    except (OSError, http.client.HTTPException):
                        raise BrokenPipeError("the server closed the connection while the "
                                              "request was sent") from None
                else:
                    raw = self._conn.getresponse()
                data = raw.read()
                resp = _Response(raw.status, {k.lower(): v for k, v in raw.getheaders()}, data)
                if resp.headers.get("connection", "").lower() == "close":
                    self._close()
            except (ConnectionRefusedError, socket.gaierror) as e:
                self._close()
                if attempt >= self.retries:
                    raise GvdConnectionError(f"cannot connect to {self.url}: {e}") from None
                time.sleep(self._delay(attempt, None))
                attempt += 1
                continue
            except (OSError, http.client.HTTPException) as e:
                # A kept-alive connection the server closed in between: one free retry.
                fresh = isinstance(e, (http.client.RemoteDisconnected, BrokenPipeError,
                                       ConnectionResetError)) and attempt == 0
                self._close()
                if idempotent and (fresh or attempt < self.retries):
                    if not fresh:
                        time.sleep(self._delay(attempt, None))
                    attempt += 1
                    continue
                raise GvdConnectionError(f"{method} {self.url}{path}: {e}") from None
            if resp.status in expect:
                return resp
            problem = self._problem(resp)
            retry_after = _retry_after(resp.headers.get("retry-after"))
            if resp.status in (429, 503) and attempt < self.retries:
                time.sleep(self._delay(attempt, retry_after))
                attempt += 1
                continue
            raise error_from_problem(problem, resp.status, retry_after)

    @staticmethod
    def _problem(resp: _Response) -> dict:
        try:
            doc = resp.json()
            if isinstance(doc, dict):
                return doc
        except ValueError:
            pass
        return {"type": "about:blank", "status": resp.status,
                "detail": resp.body[:200].decode("utf-8", "replace")}

    def _close(self) -> None:
        if self._conn is not None:
            self._conn.close()
            self._conn = None

    def close(self) -> None:
        """Closes this thread's kept-alive connection (a later request opens a new one)."""
        self._close()

    def __enter__(self) -> "Client":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def get_json(self, path: str) -> Any:
        return self.request("GET", path).json()

    # -- API

    def health(self) -> dict:
        return self.get_json("/healthz")

    def ready(self) -> dict:
        return self.get_json("/readyz")

    def jobs(self) -> list:
        """The jobs the server knows, newest first."""
        return self.get_json("/v1/jobs")["jobs"]

    def job(self, job_id: str) -> "Job":
        """A handle on an existing job (no request is made)."""
        return Job(self, job_id)

    def submit(self, scene_or_path: Union[dict, str, os.PathLike, Iterable],
               params: Optional[dict] = None) -> "Job":
        """Submits a scene; returns its ``Job`` at once (``job.wait()`` for the result).

        ``scene_or_path``: a scene dict (``{"dimension":3,"objects":[...]}``), the path of a
        scene file (.json, .obj, .glb, .gltf; or one .ply/.stl/.off mesh, labelled by its
        file stem), or a list of PLY/STL/OFF/OBJ paths, one object each, labelled by file stem
        (sent as multipart/form-data). ``params``: compute parameters (``max_depth``,
        ``contact_depth``, ``ambiguity_levels``, ``ambiguity_rounds``, ``unseen_rounds``,
        ``domain`` as a list of numbers, ...; ``mode="grid"`` with ``resolution=N``, ``metric``,
        ``float64``, ``unsigned``, ``range_cells``: the uniform-grid discrete GVD, whose
        outputs are ``graph()``, ``field_npy()`` and ``labels_npy()``; ``units="mm"``: the
        length unit, over a scene's own ``"units"``). A labelled volume: the
        path of an integer ``.npy`` with ``params={"spacing": [x, y, z]}`` (required) and
        optionally ``"background"`` (docs/API.md, "Labelled volumes").

        Jobs are content-addressed, so submitting is safe to repeat: the same scene and
        parameters give the same job (computed once).
        """
        query = {}
        for key, value in (params or {}).items():
            if key not in _PARAMS:
                raise ValueError(f"unknown parameter {key!r} (one of {', '.join(_PARAMS)})")
            if isinstance(value, bool):
                value = "true" if value else "false"
            elif isinstance(value, (list, tuple)):
                value = ",".join(repr(float(v)) for v in value)
            query[key] = str(value)
        if isinstance(scene_or_path, dict):
            body = json.dumps(scene_or_path).encode()
            ctype = "application/json"
        elif isinstance(scene_or_path, (str, os.PathLike)):
            path = os.fspath(scene_or_path)
            ext = os.path.splitext(path)[1].lower()
            with open(path, "rb") as f:
                body = f.read()
            ctype = _CONTENT_TYPES.get(ext, "application/octet-stream")
            if ext in (".ply", ".stl", ".off"):
                query["label"] = os.path.splitext(os.path.basename(path))[0]
        else:
            paths = [os.fspath(p) for p in scene_or_path]
            if not paths:
                raise ValueError("no mesh files given")
            body, ctype = _multipart(paths)
        url = "/v1/jobs" + ("?" + urllib.parse.urlencode(query) if query else "")
        resp = self.request("POST", url, body, {"Content-Type": ctype},
                            expect=(200, 201, 202, 303))
        location = resp.headers.get("location", "")
        if resp.status == 303 or not resp.body:
            doc = self.get_json(location)
        else:
            doc = resp.json()
        job = Job(self, doc.get("id") or location.rsplit("/", 1)[-1])
        job.document = doc
        job.created = resp.headers.get("x-gvd-cache", "miss") == "miss"
        return job


def _multipart(paths: Sequence[str]) -> tuple:
    boundary = "gvd-" + uuid.uuid4().hex
    out = bytearray()
    seen = set()
    for path in paths:
        base = os.path.basename(path)
        label = os.path.splitext(base)[0]
        if label in seen:
            raise ValueError(f"two files are labelled {label!r} (labels are file stems)")
        seen.add(label)
        with open(path, "rb") as f:
            content = f.read()
        quoted = label.replace("\\", "\\\\").replace('"', '\\"')
        fname = base.replace("\\", "\\\\").replace('"', '\\"')
        out += (f"--{boundary}\r\nContent-Disposition: form-data; name=\"{quoted}\"; "
                f"filename=\"{fname}\"\r\nContent-Type: application/octet-stream\r\n\r\n").encode()
        out += content + b"\r\n"
    out += f"--{boundary}--\r\n".encode()
    return bytes(out), f"multipart/form-data; boundary={boundary}"


# ------------------------------------------------------------------------------------ jobs

ProgressCallback = Callable[[str, float], None]
_FINAL = ("done", "failed", "cancelled")


class Job:
    """A job on the server. ``document`` is the last job document seen (``info()``
    refreshes it)."""

    def __init__(self, client: Client, job_id: str):
        self.client, self.id = client, job_id
        self.document: dict = {}
        self.created = False

    def __repr__(self) -> str:
        return f"Job({self.id!r}, status={self.document.get('status')!r})"

    def _path(self, suffix: str = "") -> str:
        return f"/v1/jobs/{urllib.parse.quote(self.id, safe='')}{suffix}"

    def info(self) -> dict:
        """The job document (status, progress, timings, result summary)."""
        self.document = self.client.get_json(self._path())
        return self.document

    def status(self) -> str:
        """``queued``, ``running``, ``done``, ``failed`` or ``cancelled``."""
        return self.info()["status"]

    @property
    def units(self) -> Optional[str]:
        """The scene's length unit (``"mm"``, ...) as the last job document seen says it
        (``info()`` refreshes it); None when the scene declares none."""
        if not self.document:
            self.info()
        return self.document.get("units")

    def wait(self, progress: Optional[ProgressCallback] = None,
             timeout: Optional[float] = None, poll_interval: float = 0.25) -> dict:
        """Waits until the job is finished and returns its final document; raises the job's
        error (e.g. ``LimitExceeded``, ``JobCancelled``) when it failed or was cancelled, and
        ``WaitTimeout`` after ``timeout`` seconds. Follows the job's event stream and falls
        back to polling when streams are not available. ``progress(stage, fraction)`` is
        called on every change (fraction of the whole job, 0..1)."""
        deadline = None if timeout is None else time.monotonic() + timeout
        last = [None]

        def report(doc: dict) -> None:
            self.document = doc
            if progress is None:
                return
            p = doc.get("progress") or {}
            stage = "done" if doc.get("status") == "done" else (p.get("stage") or doc.get("status", ""))
            fraction = 1.0 if doc.get("status") == "done" else float(p.get("fraction") or 0.0)
            if (stage, fraction) != last[0]:
                last[0] = (stage, fraction)
                progress(stage, fraction)

        doc = None
        try:
            doc = self._wait_events(report, deadline)
        except (TooManyStreams, GvdConnectionError, http.client.HTTPException, OSError):
            doc = None
        while doc is None or doc.get("status") not in _FINAL:
            if deadline is not None and time.monotonic() > deadline:
                raise WaitTimeout(f"job {self.id} not finished after {timeout} s")
            doc = self.info()
            report(doc)
            if doc.get("status") in _FINAL:
                break
            time.sleep(poll_interval)
        return self._final(doc)

    def _final(self, doc: dict) -> dict:
        self.document = doc
        if doc.get("status") == "done":
            return doc
        error = doc.get("error") or {"type": "/problems/job-failed", "status": 409,
                                     "detail": f"job {self.id} {doc.get('status')}"}
        raise error_from_problem(error, error.get("status"))

    def _wait_events(self, report: Callable[[dict], None],
                     deadline: Optional[float]) -> Optional[dict]:
        """Follows /events; returns the final document, or None if the stream ended early."""
        c = self.client
        read_timeout = c.timeout if deadline is None else max(0.1, min(c.timeout, deadline - time.monotonic()))
        # Heartbeats come every 10 s: never time out a healthy stream between them.
        conn = c._connect(timeout=max(read_timeout, 15.0) if deadline is None else read_timeout)
        try:
            conn.request("GET", c._prefix + self._path("/events"),
                         headers={"Accept": "text/event-stream"})
            resp = conn.getresponse()
            if resp.status != 200:
                body = resp.read()
                r = _Response(resp.status, {k.lower(): v for k, v in resp.getheaders()}, body)
                raise error_from_problem(Client._problem(r), resp.status,
                                         _retry_after(r.headers.get("retry-after")))
            event, data = "message", []
            while True:
                if deadline is not None and time.monotonic() > deadline:
                    raise WaitTimeout(f"job {self.id} not finished in time")
                line = resp.readline()
                if not line:
                    return None
                line = line.decode("utf-8").rstrip("\r\n")
                if line == "":
                    if data:
                        doc = json.loads("\n".join(data))
                        if event in _FINAL or event == "status":
                            report(doc)
                        if event in _FINAL:
                            return doc
                        if event == "gone":
                            raise NotFound({"type": "/problems/not-found", "status": 404,
                                            "detail": f"job {self.id} was removed"}, 404)
                    event, data = "message", []
                elif line.startswith(":"):
                    continue
                elif line.startswith("event:"):
                    event = line[6:].strip()
                elif line.startswith("data:"):
                    data.append(line[5:].lstrip(" "))
        except socket.timeout:
            if deadline is not None and time.monotonic() > deadline:
                raise WaitTimeout(f"job {self.id} not finished in time") from None
            return None
        finally:
            conn.close()

    def cancel(self) -> Optional[dict]:
        """Cancels a queued or running job (returns its document), or forgets a finished one
        and removes its files (returns None)."""
        resp = self.client.request("DELETE", self._path(), idempotent=False,
                                   expect=(200, 202, 204))
        return resp.json() if resp.status != 204 and resp.body else None

    # -- outputs (the job must be done: JobNotFinished otherwise)

    def glb(self) -> bytes:
        """The GVD as binary glTF (one node per object's cell, EXT_mesh_features)."""
        return self.client.request("GET", self._path("/gvd.glb")).body

    def gltf(self) -> dict:
        """The GVD as glTF JSON (buffer embedded as a data URI)."""
        return self.client.get_json(self._path("/gvd.gltf"))

    def gvd_json(self) -> dict:
        """The GVD with float64 coordinates."""
        return self.client.get_json(self._path("/gvd.json"))

    def graph(self) -> dict:
        """The dual graph: nodes (objects) and edges (neighbouring pairs, area, clearance)."""
        return self.client.get_json(self._path("/graph"))

    def field_npy(self, **query: Any) -> bytes:
        """``field.npy``: a grid job's own distance grid (no arguments), or the finished
        adaptive result sampled on a grid (``resolution=N``, ``metric``, ``float64``,
        ``unsigned``, ``domain``), as the bytes of a numpy .npy file."""
        return self._grid("/field.npy", query)

    def labels_npy(self, **query: Any) -> bytes:
        """``labels.npy``: the nearest object per cell (int32, -1 = none), as field_npy."""
        return self._grid("/labels.npy", query)

    def _grid(self, suffix: str, query: dict) -> bytes:
        q = {k: ("true" if v is True else "false" if v is False else
                 ",".join(repr(float(x)) for x in v) if isinstance(v, (list, tuple)) else str(v))
             for k, v in query.items()}
        path = self._path(suffix) + ("?" + urllib.parse.urlencode(q) if q else "")
        return self.client.request("GET", path).body

    def result_file(self) -> bytes:
        """The whole result in the engine's file format (``gvd info``, local queries)."""
        return self.client.request("GET", self._path("/result.gvd")).body

    # -- queries

    def neighbors(self, label: str, ring: int = 1) -> dict:
        """Objects within ``ring`` rings of ``label`` in the dual graph."""
        return self.client.get_json(
            self._path(f"/objects/{urllib.parse.quote(label, safe='')}/neighbors?ring={int(ring)}"))

    def nearest(self, points: Sequence) -> Union[dict, list]:
        """Nearest object and distance: one point ``[x, y(, z)]`` gives one answer, a list of
        points a list of answers (one batch request)."""
        pts = list(points)
        if pts and all(isinstance(v, (int, float)) for v in pts):
            q = ",".join(repr(float(v)) for v in pts)
            return self.client.get_json(self._path("/nearest?point=" + urllib.parse.quote(q)))
        body = json.dumps({"points": [[float(v) for v in p] for p in pts]}).encode()
        resp = self.client.request("POST", self._path("/nearest"), body,
                                   {"Content-Type": "application/json"})
        return resp.json()["answers"]

    def path(self, a: Sequence[float], b: Sequence[float], min_clearance: float = 0,
             cost: str = "shortest") -> dict:
        """A path on the GVD from ``a`` to ``b``; raises ``NoPath`` (whose ``.path`` is the
        document with empty ``points`` and a ``reason``) when none exists."""
        body = json.dumps({"from": [float(v) for v in a], "to": [float(v) for v in b],
                           "min_clearance": float(min_clearance), "cost": cost}).encode()
        resp = self.client.request("POST", self._path("/paths"), body,
                                   {"Content-Type": "application/json"})
        return resp.json()

    def explode(self, anchor: str, scale: Optional[float] = None,
                glb: bool = False) -> Union[dict, bytes]:
        """Exploded view around ``anchor``: displacement per object (dict), or with
        ``glb=True`` an animated GLB (bytes)."""
        q = {"anchor": anchor}
        if scale is not None:
            q["scale"] = repr(float(scale))
        if glb:
            q["format"] = "glb"
        resp = self.client.request("GET", self._path("/explode?" + urllib.parse.urlencode(q)))
        return resp.body if glb else resp.json()

    def tight(self, below: float) -> dict:
        """Neighbouring pairs whose interface comes closer than ``below``, tightest first."""
        return self.client.get_json(self._path(f"/tight?below={float(below)!r}"))
