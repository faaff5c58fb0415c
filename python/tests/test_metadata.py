"""The installed package says what a package index shows: its licence, its
classifiers and this package's README as its description."""

import importlib.metadata
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]


def test_the_metadata_names_the_licence_and_shows_the_package_readme():
    meta = importlib.metadata.metadata("mfcbeam")
    licence = meta.get("License-Expression") or meta.get("License")
    assert licence == "MIT OR Apache-2.0"
    classifiers = meta.get_all("Classifier")
    assert "License :: OSI Approved :: MIT License" in classifiers
    assert "License :: OSI Approved :: Apache Software License" in classifiers
    assert "Programming Language :: Rust" in classifiers
    assert meta["Requires-Python"] == ">=3.9"
    description = meta.get_payload() or meta.get("Description", "")
    assert description.strip() == (HERE / "README.md").read_text().strip()
    assert meta["Description-Content-Type"].startswith("text/markdown")
