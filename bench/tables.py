"""A bench's figures as a CSV and, beside it, the Markdown table the README and docs quote.

    tables.write(path, fields, rows, title, columns=[("seconds", "time", tables.seconds), ...])
    tables.write_markdown(path, title, columns)      # the .md again from an existing CSV

The Markdown is always made from the CSV file itself, so the two never disagree. `columns` picks and
formats what the table shows ([(field, header, format)], format None = as written); the CSV keeps
every field. Plain Python: no Blender, no numpy.
"""
import csv
import os

RESULTS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "results")


def path_for(name, quick=False):
    """bench/results/NAME.csv, or NAME_quick.csv for a quick run (ignored by git)."""
    os.makedirs(RESULTS, exist_ok=True)
    return os.path.join(RESULTS, name + ("_quick" if quick else "") + ".csv")


def kept_rows(path, measured, key):
    """The CSV's rows at `path` with those just measured put in their place (rows match where their
    `key` fields do), and the rows new to it after them: a run of a few cases keeps the others."""
    fresh = {tuple(r[k] for k in key): r for r in measured}
    rows = []
    if os.path.exists(path):
        with open(path, newline="") as f:
            rows = [fresh.pop(tuple(r[k] for k in key), r) for r in csv.DictReader(f)]
    return rows + list(fresh.values())


def write(path, fields, rows, title, columns=None, notes=""):
    """Write rows (dicts) to the CSV at `path`, then its Markdown table beside it."""
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fields, extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
    write_markdown(path, title, columns, notes)


def write_markdown(path, title, columns=None, notes=""):
    """Write PATH.md (PATH without .csv) from the CSV at `path`: a title, the table, then the notes."""
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        rows = list(reader)
        columns = columns or [(name, name, None) for name in reader.fieldnames]
    lines = [f"# {title}", "", f"Written by the bench from `{os.path.basename(path)}`.", "",
             "| " + " | ".join(header for _, header, _ in columns) + " |",
             "|" + "---|" * len(columns)]
    for row in rows:
        cells = [(fmt(row[field]) if fmt and row.get(field) not in (None, "") else row.get(field) or "-")
                 for field, _, fmt in columns]
        lines.append("| " + " | ".join(c.replace("|", "/") for c in cells) + " |")
    if notes:
        lines += ["", notes.strip()]
    with open(os.path.splitext(path)[0] + ".md", "w") as f:
        f.write("\n".join(lines) + "\n")


# Formats for `columns`: CSV text in, table text out.
def percent(s):
    return f"{float(s):.2%}"


def seconds(s):
    v = float(s)
    return f"{v:.3g} s" if v < 100 else f"{v:.0f} s"


def count(s):
    return f"{float(s):,.0f}"


def mega(s):
    return f"{float(s) / 1e6:,.1f} M"


def fixed(digits):
    return lambda s: f"{float(s):.{digits}f}"
