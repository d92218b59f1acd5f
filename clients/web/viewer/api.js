// The gvd HTTP API as the viewer uses it (docs/API.md): submitting scenes, following a job's
// events, JSON queries. Every failure becomes an ApiError carrying the problem document.

/** An HTTP error with the server's problem document (RFC 9457) when there is one. */
export class ApiError extends Error {
  constructor(status, problem, fallback) {
    const title = problem?.title ?? `HTTP ${status}`;
    const detail = problem?.detail ?? fallback ?? '';
    super(detail ? `${title}: ${detail}` : title);
    this.status = status;
    this.problem = problem ?? null;
  }
}

async function failure(res) {
  const text = await res.text();
  let problem = null;
  try {
    problem = JSON.parse(text);
  } catch {
    // not JSON: keep the text
  }
  return new ApiError(res.status, problem, problem ? undefined : text.slice(0, 200));
}

async function request(url, options = {}) {
  let res;
  try {
    res = await fetch(url, options);
  } catch (e) {
    throw new Error(`cannot reach the server (${e.message})`);
  }
  if (!res.ok) throw await failure(res);
  return res;
}

export async function getJSON(url) {
  return (await request(url)).json();
}

export async function postJSON(url, body) {
  const res = await request(url, {
    method: 'POST',
    headers: {'Content-Type': 'application/json'},
    body: JSON.stringify(body),
  });
  return res.json();
}

/** DELETE: cancels a queued or running job (docs/API.md). */
export async function cancelJob(id) {
  await request(`/v1/jobs/${encodeURIComponent(id)}`, {method: 'DELETE'});
}

export async function getBytes(url) {
  return (await request(url)).arrayBuffer();
}

/** The file name without directory and extension: the label of a mesh file's object. */
export function stem(name) {
  const base = name.split(/[\\/]/).pop();
  const dot = base.lastIndexOf('.');
  return dot > 0 ? base.slice(0, dot) : base;
}

const kTypes = {
  json: 'application/json',
  gltf: 'model/gltf+json',
  glb: 'model/gltf-binary',
  obj: 'model/obj',
  stl: 'model/stl',
  ply: 'model/x-ply',
  off: 'application/octet-stream',
};

/**
 * Submits mesh files as one job: one file as the body (scene JSON, OBJ, GLB/glTF, or a single
 * PLY/STL/OFF labelled by its name), several as multipart/form-data (one object per file,
 * part name = file name without extension). `params` go in the query string.
 * Returns the job document.
 */
export async function submitFiles(files, params = {}) {
  if (files.length === 0) throw new Error('no file chosen');
  const query = new URLSearchParams();
  for (const [k, v] of Object.entries(params)) {
    if (v !== '' && v !== undefined && v !== null) query.set(k, String(v));
  }
  let body;
  const headers = {};
  if (files.length === 1) {
    const file = files[0];
    const ext = file.name.split('.').pop().toLowerCase();
    body = file;
    headers['Content-Type'] = kTypes[ext] ?? 'application/octet-stream';
    if (['ply', 'stl', 'off'].includes(ext)) query.set('label', stem(file.name));
  } else {
    body = new FormData();
    const seen = new Set();
    for (const file of files) {
      const label = stem(file.name);
      if (seen.has(label)) throw new Error(`two files are named "${label}": labels must be unique`);
      seen.add(label);
      body.append(label, file, file.name);
    }
  }
  const qs = query.toString();
  const res = await request(`/v1/jobs${qs ? '?' + qs : ''}`, {method: 'POST', headers, body});
  return res.json();
}

const kFinal = new Set(['done', 'failed', 'cancelled']);

/**
 * Follows a job until it ends: server-sent events (/v1/jobs/{id}/events), or polling when the
 * server has no stream to spare (503) or the stream breaks. Calls onStatus(doc) for every
 * update with how it came ('events' or 'poll'); resolves with the final job document, or
 * with null when `signal` aborts first (the stream is closed then).
 */
export function watchJob(id, onStatus, signal) {
  return new Promise((resolve, reject) => {
    let finished = false;
    let source = null;
    signal?.addEventListener('abort', () => {
      if (finished) return;
      finished = true;
      source?.close();
      resolve(null);
    });
    const finish = (doc, via) => {
      if (finished) return;
      finished = true;
      onStatus(doc, via);
      resolve(doc);
    };
    const poll = async () => {
      while (!finished) {
        try {
          const doc = await getJSON(`/v1/jobs/${encodeURIComponent(id)}`);
          if (kFinal.has(doc.status)) finish(doc, 'poll');
          else onStatus(doc, 'poll');
        } catch (e) {
          finished = true;
          reject(e);
          return;
        }
        await new Promise((r) => setTimeout(r, 500));
      }
    };
    if (typeof EventSource === 'undefined') {
      poll();
      return;
    }
    source = new EventSource(`/v1/jobs/${encodeURIComponent(id)}/events`);
    const onEvent = (e) => {
      const doc = JSON.parse(e.data);
      if (kFinal.has(doc.status)) {
        source.close();
        finish(doc, 'events');
      } else {
        onStatus(doc, 'events');
      }
    };
    for (const name of ['status', 'done', 'failed', 'cancelled']) source.addEventListener(name, onEvent);
    source.addEventListener('gone', () => {
      source.close();
      finished = true;
      reject(new Error(`job ${id} was removed`));
    });
    source.onerror = () => {
      // A refused (503) or broken stream: poll instead, without EventSource's own retries.
      source.close();
      if (!finished) poll();
    };
  });
}
