// Steinmetz solid: the intersection of three perpendicular cylinders of radius 10 (written for isoforge's tests).
intersection() {
    cylinder(h = 40, r = 10, center = true);
    rotate([90, 0, 0]) cylinder(h = 40, r = 10, center = true);
    rotate([0, 90, 0]) cylinder(h = 40, r = 10, center = true);
}
