"""What LeRobot's own writer makes, and what its loader accepts (issue 71's groundwork).

Outside CI: needs `pip install -r scripts/lerobot-requirements.txt` (LeRobot's standalone
loader, `lerobot-dataset`, imported as `ledataset`, with torch). Writes only under a
temporary directory and prints:

1. the files, `meta/info.json` and every Parquet schema of a two-episode dataset written by
   `LeRobotDataset.create` / `add_frame` / `save_episode` / `finalize` with a [pins, 2]
   tactile feature, a state, an action and a slip flag;
2. whether the loader still reads the data when its Parquet files are rewritten the way a
   writer without Arrow would write them: plain list<list<float>> and list<float> columns,
   no compression, no Arrow extension types and no schema metadata (it does); and whether
   the tasks file survives losing its pandas metadata (it does not: the task strings are
   the pandas index, so a frame's task comes back as a number).

    python scripts/lerobot_probe.py
"""

import json
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
from ledataset.datasets.lerobot_dataset import LeRobotDataset

FEATURES = {
    "observation.tactile.0": {"dtype": "float32", "shape": (4, 2), "names": ["pin", "xy"]},
    "observation.state": {"dtype": "float32", "shape": (3,), "names": ["a", "b", "c"]},
    "action": {"dtype": "float32", "shape": (3,), "names": ["a", "b", "c"]},
    "slip": {"dtype": "bool", "shape": (1,), "names": None},
}


def write(root: Path) -> None:
    ds = LeRobotDataset.create("tmo/probe", fps=60, features=FEATURES, root=root, use_videos=False)
    for episode in range(2):
        for i in range(5):
            ds.add_frame(
                {
                    "observation.tactile.0": np.full((4, 2), i, np.float32),
                    "observation.state": np.zeros(3, np.float32),
                    "action": np.ones(3, np.float32),
                    "slip": np.array([i > 2]),
                    "task": f"task {episode}",
                }
            )
        ds.save_episode()
    ds.finalize()


def plain(table: pa.Table) -> pa.Table:
    """The table as a writer without Arrow's extension types would write it."""
    columns = {}
    for name in table.column_names:
        values = table.column(name).to_pylist()
        if name == "observation.tactile.0":
            columns[name] = pa.array(values, type=pa.list_(pa.list_(pa.float32())))
        elif name in ("observation.state", "action"):
            columns[name] = pa.array(values, type=pa.list_(pa.float32()))
        else:
            columns[name] = pa.array(values, type=table.schema.field(name).type)
    return pa.table(columns)


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp) / "written"
        write(root)
        for f in sorted(root.rglob("*")):
            print(f.relative_to(root))
        print(json.dumps(json.load(open(root / "meta/info.json")), indent=1))
        for f in sorted(root.rglob("*.parquet")):
            print(f.relative_to(root), pq.read_metadata(f).row_group(0).column(0).compression)
            print(pq.read_schema(f))

        rewritten = Path(tmp) / "plain"
        shutil.copytree(root, rewritten)
        data = rewritten / "data/chunk-000/file-000.parquet"
        pq.write_table(plain(pq.read_table(data)), data, compression="NONE", store_schema=False)
        episodes = rewritten / "meta/episodes/chunk-000/file-000.parquet"
        table = pq.read_table(episodes).replace_schema_metadata(None)
        pq.write_table(table, episodes, compression="NONE", store_schema=False)
        ds = LeRobotDataset("tmo/probe", root=rewritten)
        frame = ds[7]
        print("plain data and episodes files load:", len(ds), "frames at", ds.meta.fps, "fps;",
              "frame 7's tactile", frame["observation.tactile.0"].tolist(), "task", frame["task"])

        tasks = rewritten / "meta/tasks.parquet"
        pq.write_table(pq.read_table(tasks).replace_schema_metadata(None), tasks, store_schema=False)
        ds = LeRobotDataset("tmo/probe", root=rewritten)
        print("without the tasks file's pandas metadata, frame 7's task is", repr(ds[7]["task"]))


if __name__ == "__main__":
    main()
