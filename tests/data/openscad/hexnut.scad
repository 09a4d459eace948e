// A hexagonal nut: $fn = 6 asks for a hexagonal prism, a round hole through it (written for isoforge's tests).
difference() {
    cylinder(h = 8, r = 10, $fn = 6);
    translate([0, 0, -1]) cylinder(h = 10, r = 5);
    translate([0, 0, 8]) rotate([0, 0, 0]) sphere(r = 1.5);
}
