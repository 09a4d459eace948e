// Twisted and tapered linear extrusions and a partial rotate_extrude, as OpenSCAD exports them.
linear_extrude(height = 20, twist = 90, scale = 0.5, slices = 200) square(10, center = true);
translate([25, 0, 0]) linear_extrude(height = 15, twist = -120, slices = 200)
    polygon([[0, 0], [8, 0], [8, 3], [3, 3], [3, 8], [0, 8]]);
translate([0, 30, 0]) rotate_extrude(angle = 270) translate([8, 0]) circle(r = 3);
