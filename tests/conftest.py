import pytest

from fsivsp.geometry import paper_channel, refined


@pytest.fixture(scope="session")
def paper_meshes():
    """The paper's coarse mesh and its first two refinements (with projection)."""
    coarse = paper_channel()
    return [refined(coarse, level) for level in range(3)]
