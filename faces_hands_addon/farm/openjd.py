# SPDX-License-Identifier: GPL-3.0-or-later
"""A jobs manifest as an Open Job Description job bundle (specification ``jobtemplate-2023-09``), the
format farms such as AWS Deadline Cloud run (``deadline bundle submit DIR``) and ``openjd run`` runs locally.

The bundle follows the conventions of Deadline Cloud's own Blender submitter: PascalCase job parameters,
``PATH`` parameters with their data flow (the manifest, the extension zip and every audio input IN, the
output folder OUT, so job attachments carry them), Blender taken from ``PATH`` (a queue's conda environment
puts it there) unless ``BlenderExecutable`` names another, and ``template.json``, ``parameter_values.json``
and ``asset_references.json`` side by side. JSON, not YAML: the engine ships no YAML library and every
OpenJD reader takes both.

* A job **environment** checks the Blender version against the zip's own manifest and installs the zip
  into a Blender user folder private to the session (``blender --command extension install-file``), which
  every later action of the session uses through ``BLENDER_USER_RESOURCES``; ``CacheDir``, a folder of the
  worker's, keeps the settled target shapes warm from session to session (``FH_CACHE_DIR``).
* Step ``BakeRows``: one task per chunk of ``ChunkSize`` rows (task parameter ``FirstRow``), each one
  Blender process that builds the rig once and runs its rows (``faces_hands jobs ... --first-row``).
* Step ``MergeReports`` (after every chunk): one report for the whole job in the output folder.
"""
from __future__ import annotations

import json
from pathlib import Path

__all__ = ["BUNDLE_FILES", "job_template", "parameter_values", "asset_references", "write_bundle",
           "openjd_run_command", "SETUP_SCRIPT"]

BUNDLE_FILES = ("template.json", "parameter_values.json", "asset_references.json")
USER_FOLDER = "{{Session.WorkingDirectory}}/blender-user"

#: run by Blender itself in the environment's onEnter: version check, then the install into the session's
#: user folder, then the folder handed to the session's later actions (``openjd_env``)
SETUP_SCRIPT = '''\
import os, subprocess, sys, tomllib, zipfile
import bpy
blender, zip_path, user_dir, cache_dir = sys.argv[sys.argv.index("--") + 1:][:4]
with zipfile.ZipFile(zip_path) as archive:
    manifest = tomllib.loads(archive.read("blender_manifest.toml").decode("utf-8"))
def version(text):
    return tuple(int(part) for part in text.split(".")[:3])
low = version(manifest["blender_version_min"])
high = version(manifest.get("blender_version_max", "999.0.0"))
here = tuple(bpy.app.version)
print(f"Blender {bpy.app.version_string}; {manifest['id']} {manifest['version']} takes "
      f"{manifest['blender_version_min']} <= Blender < {manifest.get('blender_version_max', 'any')}", flush=True)
if not low <= here < high:
    raise SystemExit(f"error: Blender {bpy.app.version_string} is outside the range of {os.path.basename(zip_path)}")
os.makedirs(user_dir, exist_ok=True)
env = dict(os.environ, BLENDER_USER_RESOURCES=user_dir)
subprocess.run([blender, "--command", "extension", "install-file", "--repo", "user_default", "--enable",
                zip_path], env=env, check=True)
print(f"openjd_env: BLENDER_USER_RESOURCES={user_dir}", flush=True)
if cache_dir:
    os.makedirs(cache_dir, exist_ok=True)
    print(f"openjd_env: FH_CACHE_DIR={cache_dir}", flush=True)
'''


def _path_parameter(name: str, kind: str, flow: str, description: str) -> dict:
    control = {("FILE", "IN"): "CHOOSE_INPUT_FILE", ("DIRECTORY", "OUT"): "CHOOSE_DIRECTORY"}[(kind, flow)]
    return {"name": name, "type": "PATH", "objectType": kind, "dataFlow": flow, "description": description,
            "userInterface": {"control": control, "label": name}}


def _blender_action(args: list[str], timeout: int | None = None) -> dict:
    action = {"command": "{{Param.BlenderExecutable}}", "args": args,
              "cancelation": {"mode": "NOTIFY_THEN_TERMINATE"}}
    if timeout:
        action["timeout"] = timeout
    return action


def _jobs_args(rig: bool) -> list[str]:
    args = ["-b", "-c", "faces_hands", "jobs", "{{Param.ManifestFile}}", "--out-dir", "{{Param.OutputDir}}",
            "--fps", "{{Param.Fps}}"]
    return args + (["--rig", "{{Param.RigFile}}"] if rig else [])


def job_template(name: str, rows: int, chunk: int, fps: float, rig: bool = False) -> dict:
    """The job template for a manifest of ``rows`` rows in chunks of ``chunk`` (``rig``: the run uses a
    rig file, a further IN parameter)."""
    parameters = [
        _path_parameter("ManifestFile", "FILE", "IN", "The jobs manifest (CSV or JSON Lines); relative "
                                                      "inputs are read from its folder."),
        _path_parameter("OutputDir", "DIRECTORY", "OUT", "Where every row's outputs, sidecars and the "
                                                         "report go."),
        _path_parameter("ExtensionZip", "FILE", "IN", "The Faces & Hands extension zip for the workers' "
                                                      "platform and Blender line."),
        {"name": "BlenderExecutable", "type": "STRING", "default": "blender",
         "description": "Blender on the worker (default: found on PATH, as a conda queue environment sets it)."},
        {"name": "ChunkSize", "type": "INT", "default": chunk, "minValue": 1,
         "description": "Rows per task: each task is one Blender process that builds the rig once."},
        {"name": "Fps", "type": "FLOAT", "default": fps, "minValue": 1, "maxValue": 240,
         "description": "Frame rate of the animations."},
        {"name": "CacheDir", "type": "PATH", "objectType": "DIRECTORY", "dataFlow": "NONE", "default": "",
         "description": "A folder on the worker that keeps the settled target shapes and compiled code from "
                        "session to session (empty: each session computes them anew, about 30 s)."},
    ]
    if rig:
        parameters.append(_path_parameter("RigFile", "FILE", "IN", "The .blend with the face rig."))
    environment = {
        "name": "FacesHandsExtension",
        "description": "Checks the Blender version and installs the extension zip into a Blender user "
                       "folder of the session's own.",
        "script": {
            "embeddedFiles": [{"name": "Setup", "type": "TEXT", "filename": "fh_setup.py", "data": SETUP_SCRIPT}],
            "actions": {"onEnter": _blender_action(
                ["-b", "--factory-startup", "--python-exit-code", "1", "--python", "{{Env.File.Setup}}", "--",
                 "{{Param.BlenderExecutable}}", "{{Param.ExtensionZip}}", USER_FOLDER, "{{Param.CacheDir}}"],
                timeout=1800)}}}
    bake = {"name": "BakeRows",
            "parameterSpace": {"taskParameterDefinitions": [
                {"name": "FirstRow", "type": "INT", "range": f"1-{max(rows, 1)}:{{{{Param.ChunkSize}}}}"}]},
            "script": {"actions": {"onRun": _blender_action(
                _jobs_args(rig) + ["--chunk", "{{Param.ChunkSize}}", "--first-row", "{{Task.Param.FirstRow}}"])}}}
    merge = {"name": "MergeReports", "dependencies": [{"dependsOn": "BakeRows"}],
             "script": {"actions": {"onRun": _blender_action(_jobs_args(rig) + ["--merge-reports"])}}}
    return {"specificationVersion": "jobtemplate-2023-09", "name": f"Faces & Hands jobs: {name}"[:128],
            "description": f"{rows} rows of {name} in chunks of {chunk}",
            "parameterDefinitions": parameters, "jobEnvironments": [environment], "steps": [bake, merge]}


def parameter_values(manifest: Path, out_dir: Path, extension_zip: Path, blender: str, chunk: int, fps: float,
                     rig: Path | None = None) -> dict:
    values = {"ManifestFile": str(manifest), "OutputDir": str(out_dir), "ExtensionZip": str(extension_zip),
              "BlenderExecutable": blender, "ChunkSize": chunk, "Fps": fps}
    if rig is not None:
        values["RigFile"] = str(rig)
    return {"parameterValues": [{"name": name, "value": value} for name, value in values.items()]}


def asset_references(inputs: list[Path], out_dir: Path) -> dict:
    """Deadline Cloud's job-attachment list: every input file (manifest, zip, rig, audio) and the output
    folder, each once."""
    return {"assetReferences": {"inputs": {"filenames": sorted({str(p) for p in inputs}), "directories": []},
                                "outputs": {"directories": [str(out_dir)]}}}


def write_bundle(folder: Path, template: dict, values: dict, assets: dict) -> list[Path]:
    """Write the bundle's three files into ``folder`` (created; files of an older bundle replaced)."""
    folder.mkdir(parents=True, exist_ok=True)
    written = []
    for name, doc in zip(BUNDLE_FILES, (template, values, assets)):
        path = folder / name
        tmp = folder / (name + ".tmp")
        tmp.write_text(json.dumps(doc, indent=1, ensure_ascii=False) + "\n", encoding="utf-8")
        tmp.replace(path)
        written.append(path)
    return written


def openjd_run_command(folder: Path, values: dict) -> list[str]:
    """``openjd run`` of the bundle with its parameter values (that command takes ``Name=Value`` pairs,
    not Deadline's ``parameterValues`` list)."""
    command = ["openjd", "run", str(folder / "template.json")]
    for entry in values["parameterValues"]:
        command += ["-p", f"{entry['name']}={entry['value']}"]
    return command
