"""Meshes from robot and world files: found (``paths``), checked and read (``load``), turned into what the
simulator collides with (``collision``) and what it draws (``visual``), once, and cached on disk by the file's
content (``cache``). The simulator, the renderer and the viewer all read meshes through here, so a file that
one of them accepts is a file every one of them can use.
"""

from nodes.meshes.load import (
                               MAX_MESH_BYTES,
                               MAX_MESH_TRIANGLES,
                               MAX_ROBOT_MESH_FILES,
                               MAX_ROBOT_TRIANGLES,
                               MAX_TEXT_MESH_BYTES,
                               MeshBudget,
                               MeshData,
                               MeshError,
                               MeshPart,
                               load_mesh,
                               probe,
)

__all__ = ["MAX_MESH_BYTES", "MAX_MESH_TRIANGLES", "MAX_ROBOT_MESH_FILES", "MAX_ROBOT_TRIANGLES",
           "MAX_TEXT_MESH_BYTES", "MeshBudget", "MeshData", "MeshError", "MeshPart", "load_mesh", "probe"]
