// upload.ts -- a set upload from the browser: the files dropped or picked (folders walked with
// webkitGetAsEntry, keeping relative paths), the set's root found (module.xml at the top), the
// multipart body (`files` parts named by path, or one `archive`), and the POST with progress.
import { detailOf, sessionHeaders } from "../api/client";
import { type Place, placeIn } from "../api/place";

export interface UploadFile {
  /** path inside the set, "/"-separated, e.g. lib/cntr1.so */
  path: string;
  file: File;
}

/** The part of FileSystemEntry / FileSystemDirectoryEntry the walk needs (so tests can fake it). */
export interface EntryLike {
  isFile: boolean;
  isDirectory: boolean;
  name: string;
  file?(ok: (f: File) => void, err?: (e: unknown) => void): void;
  createReader?(): { readEntries(ok: (entries: EntryLike[]) => void, err?: (e: unknown) => void): void };
}

/** Every file under `entries`, with its path relative to the drop (a dropped folder keeps its name). */
export async function filesFromEntries(entries: EntryLike[], prefix = ""): Promise<UploadFile[]> {
  const out: UploadFile[] = [];
  for (const entry of entries) {
    const path = prefix + entry.name;
    if (entry.isFile && entry.file) {
      const file = await new Promise<File>((ok, err) => entry.file!(ok, err));
      out.push({ path, file });
    } else if (entry.isDirectory && entry.createReader) {
      const reader = entry.createReader();
      // readEntries answers in batches (100 in Chromium) until an empty one
      const children: EntryLike[] = [];
      for (;;) {
        const batch = await new Promise<EntryLike[]>((ok, err) => reader.readEntries(ok, err));
        if (!batch.length) break;
        children.push(...batch);
      }
      out.push(...(await filesFromEntries(children, `${path}/`)));
    }
  }
  return out;
}

/** Files from an <input type=file> (webkitRelativePath when a folder was picked). */
export function filesFromList(files: ArrayLike<File>): UploadFile[] {
  return Array.from(files).map((file) => ({ path: file.webkitRelativePath || file.name, file }));
}

/** The files of a drop: folders walked when the browser gives entries, plain files otherwise. */
export async function filesFromDrop(dt: DataTransfer): Promise<UploadFile[]> {
  const entries: EntryLike[] = [];
  for (const item of Array.from(dt.items ?? [])) {
    if (item.kind !== "file") continue;
    const entry = (item as DataTransferItem & { webkitGetAsEntry?: () => EntryLike | null }).webkitGetAsEntry?.();
    if (entry) entries.push(entry);
  }
  return entries.length ? filesFromEntries(entries) : filesFromList(dt.files);
}

const JUNK = /(^|\/)(\.DS_Store|Thumbs\.db|desktop\.ini|\._[^/]*|\.git(\/.*)?)$/;

export type Plan =
  | { kind: "archive"; file: File; name: string; bytes: number }
  | { kind: "files"; files: UploadFile[]; bytes: number; skipped: string[]; root: string }
  | { kind: "error"; message: string };

function isArchive(name: string): boolean {
  return /\.(tar\.gz|tgz)$/i.test(name);
}

/**
 * What to send: one .tar.gz alone as `archive`; otherwise the files, with the folder they were
 * dropped in taken off so that module.xml is at the top (a dropped "plc-robot/" folder uploads
 * as module.xml, Robot.so, ...).  Desktop litter (.DS_Store, ._*, Thumbs.db) is left out.
 */
export function planUpload(input: UploadFile[]): Plan {
  if (!input.length) return { kind: "error", message: "no files" };
  const archives = input.filter((f) => isArchive(f.path));
  if (archives.length) {
    if (input.length > 1)
      return {
        kind: "error",
        message: `send an archive alone: ${archives[0].path} came with ${input.length - 1} other file(s)`,
      };
    return {
      kind: "archive",
      file: archives[0].file,
      name: archives[0].path.split("/").pop()!,
      bytes: archives[0].file.size,
    };
  }
  const skipped = input.filter((f) => JUNK.test(f.path)).map((f) => f.path);
  let files = input.filter((f) => !JUNK.test(f.path)).map((f) => ({ ...f, path: f.path.replace(/^\/+/, "") }));
  let root = "";
  // the set's top: where module.xml is, or the sources of a set written in Structured Text or drawn in
  // PLCopen XML alone (.st, .xml: the agent tells a PLCopen project from another .xml by its root)
  const top = (f: UploadFile) => f.path === "module.xml" || (!f.path.includes("/") && /\.(st|xml)$/i.test(f.path));
  for (;;) {
    if (files.some(top)) break;
    const first = files[0].path.split("/")[0];
    if (!files.every((f) => f.path.startsWith(`${first}/`))) break;
    root += `${first}/`;
    files = files.map((f) => ({ ...f, path: f.path.slice(first.length + 1) }));
  }
  if (!files.some(top))
    return {
      kind: "error",
      message:
        "no module.xml at the top of the set (nor .st or PLCopen .xml sources to build one from): drop the set's folder, its files, or one .tar.gz",
    };
  const seen = new Set<string>();
  for (const f of files) {
    if (seen.has(f.path)) return { kind: "error", message: `${f.path} appears twice` };
    seen.add(f.path);
  }
  files.sort((a, b) => (a.path === "module.xml" ? -1 : b.path === "module.xml" ? 1 : a.path.localeCompare(b.path)));
  return { kind: "files", files, bytes: files.reduce((n, f) => n + f.file.size, 0), skipped, root };
}

/** The multipart body: one `files` part per file, its filename the path in the set; or `archive`. */
export function buildForm(plan: Exclude<Plan, { kind: "error" }>): FormData {
  const form = new FormData();
  if (plan.kind === "archive") form.append("archive", plan.file, plan.name);
  else for (const f of plan.files) form.append("files", f.file, f.path);
  return form;
}

/** One of several errors of a refusal (the ST compiler's: main.st:12:9, code `type`), with its place. */
export interface RefusalProblem extends Place {
  message: string;
  code?: string;
}

export interface Refusal extends Place {
  status: number;
  message: string;
  /** Every error, when the agent gives several (an upload's ST compile errors); the place above is the first's. */
  problems?: RefusalProblem[];
}

/** An upload's refusal from its status and body ({detail, the place's fields, and `problems`}). */
export function refusal(status: number, body: unknown): Refusal {
  let message = body === undefined || body === "" ? `HTTP ${status}` : detailOf(body);
  if (status === 0) message = body === "aborted" ? "upload cancelled" : "the agent did not answer (network error)";
  const listed = body && typeof body === "object" ? (body as { problems?: unknown }).problems : undefined;
  const problems = Array.isArray(listed)
    ? listed
        .filter((p): p is Record<string, unknown> => !!p && typeof p === "object")
        .map((p) => ({
          message: String(p.message ?? ""),
          ...(typeof p.code === "string" && p.code ? { code: p.code } : {}),
          ...placeIn(p),
        }))
    : [];
  return { status, message, ...placeIn(body), ...(problems.length ? { problems } : {}) };
}

export interface UploadHandle {
  done: Promise<{ status: number; body: unknown }>;
  abort(): void;
}

/** POSTs `form` with XMLHttpRequest, to report upload progress (fetch cannot); the session cookie
 * signs it in, `csrf` is the session's CSRF token. */
export function send(
  url: string,
  csrf: string,
  form: FormData,
  onProgress: (sent: number, total: number) => void,
): UploadHandle {
  const xhr = new XMLHttpRequest();
  const done = new Promise<{ status: number; body: unknown }>((resolve) => {
    xhr.open("POST", url);
    for (const [k, v] of Object.entries(sessionHeaders("POST", csrf))) xhr.setRequestHeader(k, v);
    xhr.upload.onprogress = (e) => onProgress(e.loaded, e.lengthComputable ? e.total : 0);
    const finish = () => {
      let body: unknown = xhr.responseText;
      try {
        body = JSON.parse(xhr.responseText);
      } catch {
        /* not JSON: keep the text */
      }
      resolve({ status: xhr.status, body });
    };
    xhr.onload = finish;
    xhr.onerror = finish;
    xhr.onabort = () => resolve({ status: 0, body: "aborted" });
    xhr.send(form);
  });
  return { done, abort: () => xhr.abort() };
}
