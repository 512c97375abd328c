"""What several test modules share that is not a fixture (those are conftest.py's): run cases and their
helpers (`cases`), meshes written as files (`meshes`)."""
