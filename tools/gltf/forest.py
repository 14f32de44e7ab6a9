"""Generates the instancing scale scene: N instances (default 1000) of one icosphere of
327,680 triangles (trimesh's icosphere, 7 subdivisions) on a grid, with a camera, as a GLB
(the mesh stored once; every node places it). Used by `make forest`.

    python3 tools/gltf/forest.py 1000 target/forest.glb

Measured here (2 threads, 1920 x 1080, `/usr/bin/time -v`): 1000 instances = 327.7 M
triangles as rays see them, peak RSS 172 MB (Embree) / 170 MB (native) against 154 / 146 MB
for the same file with one node (a single flattened copy); render 1.5 s / 1.8 s.
"""

import sys, struct, base64, numpy as np, trimesh, pygltflib as g
n = int(sys.argv[1]); out = sys.argv[2]
m = trimesh.creation.icosphere(subdivisions=7)
pos = m.vertices.astype('<f4'); idx = m.faces.astype('<u4')
blob = pos.tobytes() + idx.tobytes()
nodes = []
side = int(np.ceil(np.sqrt(n)))
for k in range(n):
    i, j = k % side, k // side
    nodes.append(g.Node(mesh=0, translation=[float(i*2.5 - side*1.25), float(j*2.5 - side*1.25), 0.0]))
nodes.append(g.Node(camera=0, translation=[0, 0, side*3.0]))
doc = g.GLTF2(scene=0, scenes=[g.Scene(nodes=list(range(n+1)))], nodes=nodes,
  meshes=[g.Mesh(primitives=[g.Primitive(attributes=g.Attributes(POSITION=0), indices=1)])],
  cameras=[g.Camera(type="perspective", perspective=g.Perspective(yfov=0.9, aspectRatio=16/9, znear=0.1))],
  accessors=[g.Accessor(bufferView=0, componentType=g.FLOAT, count=len(pos), type=g.VEC3, min=pos.min(0).tolist(), max=pos.max(0).tolist()),
             g.Accessor(bufferView=1, componentType=g.UNSIGNED_INT, count=idx.size, type=g.SCALAR)],
  bufferViews=[g.BufferView(buffer=0, byteLength=pos.nbytes), g.BufferView(buffer=0, byteOffset=pos.nbytes, byteLength=idx.nbytes)],
  buffers=[g.Buffer(byteLength=len(blob))])
doc.set_binary_blob(blob)
doc.save_binary(out)
print(len(idx), "triangles per prototype,", n, "instances")
