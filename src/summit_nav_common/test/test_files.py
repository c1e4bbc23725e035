"""files.load_yaml: the document, or the caller's error naming the file and the fault."""
import pytest

from summit_nav_common.files import load_yaml


class MyError(ValueError):
    pass


def test_the_document_and_an_empty_file(tmp_path):
    path = tmp_path / "a.yaml"
    path.write_text("a: [1, 2]\nb: {c: x}\n")
    assert load_yaml(str(path)) == {"a": [1, 2], "b": {"c": "x"}}
    path.write_text("")
    assert load_yaml(str(path)) is None


@pytest.mark.parametrize("content, fault", [
    (None, r"cannot read it \(No such file or directory\)"),
    (b"a: [1, 2\n", r"malformed YAML \(not YAML from line 2, column 1\)"),
    (b"a: \xff\xfe\n", r"not UTF-8 text"),
])
def test_an_unusable_file_raises_the_callers_error_naming_it(tmp_path, content, fault):
    path = tmp_path / "a.yaml"
    if content is not None:
        path.write_bytes(content)
    with pytest.raises(MyError, match=r"^waypoint file " + str(path) + ": " + fault):
        load_yaml(str(path), MyError, "waypoint file")
    with pytest.raises(ValueError, match=r"^" + str(path) + ": " + fault):
        load_yaml(str(path))
