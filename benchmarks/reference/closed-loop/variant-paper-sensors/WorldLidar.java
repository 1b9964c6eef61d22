import it.units.erallab.hmsrobots.core.objects.Voxel;
import it.units.erallab.hmsrobots.core.sensors.Lidar;
import it.units.erallab.hmsrobots.core.sensors.Sensor;
import org.dyn4j.dynamics.RaycastResult;
import org.dyn4j.geometry.Ray;

import java.util.ArrayList;
import java.util.Arrays;
import java.util.List;

/**
 * 2D-VSR-Sim 1.9.2's Lidar (core/sensors/Lidar.java) with its rays fixed in the world frame: the
 * same raycast from the voxel's centre, with the same filter, reading distance / rayLength (1 when
 * nothing is hit within rayLength), but without adding voxel.getAngle() to each ray's direction.
 */
public class WorldLidar implements Sensor {
  private final double rayLength;
  private final double[] rayDirections;
  private final Domain[] domains;

  public WorldLidar(double rayLength, double... rayDirections) {
    this.rayLength = rayLength;
    this.rayDirections = rayDirections.clone();
    domains = new Domain[rayDirections.length];
    Arrays.fill(domains, Domain.of(0d, 1d));
  }

  @Override
  public Domain[] domains() {
    return domains;
  }

  @Override
  public double[] sense(Voxel voxel, double t) {
    double[] rayHits = new double[rayDirections.length];
    List<RaycastResult> results = new ArrayList<>();
    for (int i = 0; i < rayDirections.length; i++) {
      Ray ray = new Ray(voxel.getCenter(), rayDirections[i]);
      results.clear();
      voxel.getWorld().raycast(ray, rayLength, new Lidar.RaycastFilter(), true, false, false, results);
      rayHits[i] = results.isEmpty() ? 1d : results.get(0).getRaycast().getDistance() / rayLength;
    }
    return rayHits;
  }

  @Override
  public String toString() {
    return "WorldLidar{rayLength=" + rayLength + ", rayDirections=" + Arrays.toString(rayDirections) + '}';
  }
}
