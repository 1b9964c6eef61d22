import it.units.erallab.hmsrobots.core.controllers.Controller;
import it.units.erallab.hmsrobots.core.controllers.PhaseSin;
import it.units.erallab.hmsrobots.core.objects.ControllableVoxel;
import it.units.erallab.hmsrobots.core.objects.Robot;
import it.units.erallab.hmsrobots.core.objects.SensingVoxel;
import it.units.erallab.hmsrobots.core.sensors.AreaRatio;
import it.units.erallab.hmsrobots.core.sensors.Noisy;
import it.units.erallab.hmsrobots.core.sensors.Sensor;
import it.units.erallab.hmsrobots.core.sensors.SoftNormalization;
import it.units.erallab.hmsrobots.core.sensors.Touch;
import it.units.erallab.hmsrobots.core.sensors.Velocity;
import it.units.erallab.hmsrobots.tasks.locomotion.Locomotion;
import it.units.erallab.hmsrobots.tasks.locomotion.Outcome;
import it.units.erallab.hmsrobots.util.Grid;
import it.units.erallab.hmsrobots.util.RobotUtils;
import org.apache.commons.lang3.tuple.Pair;
import org.dyn4j.dynamics.Body;
import org.dyn4j.dynamics.Settings;
import org.dyn4j.geometry.Rectangle;
import org.dyn4j.geometry.Vector2;

import java.io.BufferedReader;
import java.io.FileReader;
import java.io.FileWriter;
import java.io.PrintWriter;
import java.util.*;
import java.util.concurrent.*;

/**
 * Closed-loop and high-frequency drivers for 2D-VSR-Sim v1.9.2 (dyn4j 3.3.0), written for the
 * somite fidelity check. Everything runs through the library's own Locomotion.apply(robot, null)
 * (30 s, new Settings(), the paper's placement), fitness = outcome.subOutcome(5, 30).getVelocity().
 *
 * Modes:
 *   genomes GENOMES.txt TERRAINS SIGMAS OUT.csv      every genome x terrain x sigma
 *   dump    GENOMES.txt NAME TERRAIN SIGMA OUT.csv   one episode, every control step
 *   sweep   SHAPES TERRAINS FREQS PHASES OUT.csv     open-loop PhaseSin (amp 1), area-ratio stats
 *   layout  SHAPE                                    the sensors of each voxel and their widths
 * Env: THREADS (default 2), HIDDEN (sigmoid | tanh; default sigmoid, as the authors' code),
 *   SENSORS (code | paper; default code: spinedTouchSighted, the authors' code's sensors; paper:
 *   somite's paper preset, see paperSensors), GAP (1: dump's last column is the lowest block corner's
 *   height above the terrain, see lowestGap).
 *
 * Genome file (written by export_genomes.py): blocks of
 *   G name shape n_nodes n_edges
 *   N id kind(S|H|A) x y slot          (slot -1 unless a sensor)
 *   E src_id dst_id weight bias
 */
public class CL {

  static final int K_SENSOR = 0, K_HIDDEN = 1, K_ACTUATOR = 2;

  static class G {
    String name, shape;
    int[] kind, x, y, slot;
    int[] src, dst;
    double[] w, b;
  }

  static List<G> readGenomes(String file) throws Exception {
    List<G> out = new ArrayList<>();
    try (BufferedReader r = new BufferedReader(new FileReader(file))) {
      String line;
      while ((line = r.readLine()) != null) {
        if (line.isBlank()) continue;
        String[] p = line.trim().split("\\s+");
        if (!p[0].equals("G")) throw new IllegalArgumentException("expected G, got " + line);
        G g = new G();
        g.name = p[1];
        g.shape = p[2];
        int nn = Integer.parseInt(p[3]), ne = Integer.parseInt(p[4]);
        g.kind = new int[nn]; g.x = new int[nn]; g.y = new int[nn]; g.slot = new int[nn];
        Map<Integer, Integer> pos = new HashMap<>();
        for (int i = 0; i < nn; i++) {
          String[] q = r.readLine().trim().split("\\s+");
          pos.put(Integer.parseInt(q[1]), i);
          g.kind[i] = q[2].equals("S") ? K_SENSOR : q[2].equals("H") ? K_HIDDEN : K_ACTUATOR;
          g.x[i] = Integer.parseInt(q[3]);
          g.y[i] = Integer.parseInt(q[4]);
          g.slot[i] = Integer.parseInt(q[5]);
        }
        g.src = new int[ne]; g.dst = new int[ne]; g.w = new double[ne]; g.b = new double[ne];
        for (int e = 0; e < ne; e++) {
          String[] q = r.readLine().trim().split("\\s+");
          g.src[e] = pos.get(Integer.parseInt(q[1]));
          g.dst[e] = pos.get(Integer.parseInt(q[2]));
          g.w[e] = Double.parseDouble(q[3]);
          g.b[e] = Double.parseDouble(q[4]);
        }
        out.add(g);
      }
    }
    return out;
  }

  /** The voxels of a grid in somite's order: bottom row first (y outer), x inner. */
  static List<int[]> voxelOrder(Grid<?> grid) {
    List<int[]> cells = new ArrayList<>();
    for (int y = 0; y < grid.getH(); y++) {
      for (int x = 0; x < grid.getW(); x++) {
        if (grid.get(x, y) != null) cells.add(new int[]{x, y});
      }
    }
    return cells;
  }

  static double[] flatReadings(SensingVoxel v) {
    List<Pair<Sensor, double[]>> rs = v.getLastReadings();
    int n = 0;
    for (Pair<Sensor, double[]> p : rs) n += p.getValue().length;
    double[] out = new double[n];
    int i = 0;
    for (Pair<Sensor, double[]> p : rs) for (double d : p.getValue()) out[i++] = d;
    return out;
  }

  /**
   * The SOC controller (MyController of pigozzif/SelfOrganizingVSRController, experiment-period
   * code 45caf84; original-system.md 4.2): phase 1 computes every node's message from the other
   * nodes' caches (previous step), sensors read tanh(flattened lastReadings[numSensor]) of their
   * voxel, actuators apply tanh(sum(cache*w+b)) at once; phase 2 copies message -> cache.
   */
  static class Soc implements Controller<SensingVoxel> {
    final G g;
    final boolean sigmoid;
    final int[][] in;
    double[] cache, message;
    // recording (dump mode)
    boolean record;
    List<int[]> order;
    List<double[]> rows = new ArrayList<>();
    double[][] ground;  // GAP=1: the terrain, for the lowest corner's height above it
    Robot<?> robot;
    int step;

    Soc(G g, boolean sigmoid) {
      this.g = g;
      this.sigmoid = sigmoid;
      int n = g.kind.length;
      List<List<Integer>> ins = new ArrayList<>();
      for (int i = 0; i < n; i++) ins.add(new ArrayList<>());
      for (int e = 0; e < g.src.length; e++) ins.get(g.dst[e]).add(e);
      in = new int[n][];
      for (int i = 0; i < n; i++) in[i] = ins.get(i).stream().mapToInt(Integer::intValue).toArray();
      cache = new double[n];
      message = new double[n];
    }

    @Override
    public void control(double t, Grid<? extends SensingVoxel> voxels) {
      step++;
      Map<Integer, double[]> flat = new HashMap<>();
      int n = g.kind.length;
      for (int i = 0; i < n; i++) {
        if (g.kind[i] == K_SENSOR) {
          int key = g.y[i] * 1000 + g.x[i];
          double[] r = flat.get(key);
          if (r == null) {
            r = flatReadings(voxels.get(g.x[i], g.y[i]));
            flat.put(key, r);
          }
          message[i] = Math.tanh(r[g.slot[i]]);
        } else {
          double s = 0d;
          for (int e : in[i]) s += cache[g.src[e]] * g.w[e] + g.b[e];
          if (g.kind[i] == K_HIDDEN) {
            message[i] = sigmoid ? 1d / (1d + Math.exp(-s)) : Math.tanh(s);
          } else {
            message[i] = Math.tanh(s);
            voxels.get(g.x[i], g.y[i]).applyForce(message[i]);
          }
        }
      }
      System.arraycopy(message, 0, cache, 0, n);
      if (record) {
        List<Double> row = new ArrayList<>();
        row.add((double) step);
        row.add(t);
        Vector2 c = robot.getCenter();
        row.add(c.x);
        row.add(c.y);
        for (int[] xy : order) for (double d : flatReadings(voxels.get(xy[0], xy[1]))) row.add(d);
        for (int[] xy : order) row.add(voxels.get(xy[0], xy[1]).getLastAppliedForce());
        for (int[] xy : order) row.add(voxels.get(xy[0], xy[1]).getAreaRatio());
        if (ground != null) row.add(lowestGap(voxels, order, ground));
        rows.add(row.stream().mapToDouble(Double::doubleValue).toArray());
      }
    }

    @Override
    public void reset() {
      Arrays.fill(cache, 0d);
      Arrays.fill(message, 0d);
      step = 0;
      rows.clear();
    }
  }

  static final Map<String, double[][]> TERRAINS = new ConcurrentHashMap<>();

  static double[][] terrain(String name) {
    return TERRAINS.computeIfAbsent(name, Locomotion::createTerrain);
  }

  static String sensorConfig(String sigma) {
    return Double.parseDouble(sigma) == 0d ? "spinedTouchSighted-f-f-0" : "spinedTouchSighted-f-f-" + sigma;
  }

  static final String SENSORS = System.getenv().getOrDefault("SENSORS", "code");

  static final double[] PAPER_LIDAR = {-Math.PI / 4d, -Math.PI / 8d, 0d, Math.PI / 8d, Math.PI / 4d};

  /**
   * somite's paper preset: spinedTouchSighted's layout and order (area; touch on the bottom row;
   * velocity x, y on the top row; lidar on the rightmost column), but touch without its 0.25 s
   * Average, velocity in the world frame (rotated=false) without its 0.5 s Average, and the lidar's
   * rays at -pi/4, -pi/8, 0, pi/8, pi/4 in the world frame (WorldLidar), range 10, distance / 10.
   */
  static Grid<? extends SensingVoxel> paperSensors(Grid<Boolean> body, String sigma) {
    double noiseSigma = Double.parseDouble(sigma);
    return Grid.create(body.getW(), body.getH(), (x, y) -> {
      if (!body.get(x, y)) return null;
      List<Sensor> sensors = new ArrayList<>();
      sensors.add(new SoftNormalization(new AreaRatio()));
      if (y == 0) sensors.add(new Touch());
      if (y == body.getH() - 1) sensors.add(new SoftNormalization(new Velocity(false, 8d, Velocity.Axis.X, Velocity.Axis.Y)));
      if (x == body.getW() - 1) sensors.add(new WorldLidar(10d, PAPER_LIDAR));
      List<Sensor> out = new ArrayList<>();
      for (Sensor s : sensors) out.add(noiseSigma == 0 ? s : new Noisy(s, noiseSigma, 0));
      return new SensingVoxel(out);
    });
  }

  static Grid<? extends SensingVoxel> sensorize(Grid<Boolean> s, String sigma) {
    switch (SENSORS) {
      case "code": return RobotUtils.buildSensorizingFunction(sensorConfig(sigma)).apply(s);
      case "paper": return paperSensors(s, sigma);
      default: throw new IllegalArgumentException("SENSORS must be code or paper, not " + SENSORS);
    }
  }

  @SuppressWarnings("unchecked")
  static Robot<SensingVoxel> buildRobot(String shape, String sigma, Controller<SensingVoxel> c) {
    Grid<Boolean> s = RobotUtils.buildShape(shape);
    Grid<? extends SensingVoxel> body = sensorize(s, sigma);
    return new Robot<>(c, (Grid<SensingVoxel>) body);
  }

  static String episodeRow(G g, String terrainName, String sigma, boolean sigmoid) {
    Soc c = new Soc(g, sigmoid);
    Robot<SensingVoxel> robot = buildRobot(g.shape, sigma, c);
    Locomotion loc = new Locomotion(30d, terrain(terrainName), new Settings());
    long t0 = System.nanoTime();
    Outcome o = loc.apply(robot, null);
    double secs = (System.nanoTime() - t0) / 1e9;
    Outcome sub = o.subOutcome(5d, 30d);
    List<Outcome.Observation> obs = sub.getObservations();
    Outcome.Observation first = obs.get(0), last = obs.get(obs.size() - 1);
    Outcome.Observation end = o.getObservations().get(o.getObservations().size() - 1);
    return String.format(Locale.ROOT, "java,%s,%s,%s,%s,%s,%.9f,%.6f,%.6f,%.6f,%.6f,%.3f",
        g.name, g.shape, terrainName, sigma, sigmoid ? "sigmoid" : "tanh", sub.getVelocity(),
        first.getCenterPosition().x, last.getCenterPosition().x, end.getCenterPosition().x,
        end.getCenterPosition().y, secs);
  }

  static int threads() {
    return Integer.parseInt(System.getenv().getOrDefault("THREADS", "2"));
  }

  static void genomes(String[] a) throws Exception {
    List<G> gs = readGenomes(a[1]);
    String[] terrains = a[2].split(",");
    String[] sigmas = a[3].split(",");
    boolean sigmoid = !System.getenv().getOrDefault("HIDDEN", "sigmoid").equals("tanh");
    ExecutorService pool = Executors.newFixedThreadPool(threads());
    List<Future<String>> futures = new ArrayList<>();
    for (G g : gs) for (String t : terrains) for (String s : sigmas) {
      futures.add(pool.submit(() -> episodeRow(g, t, s, sigmoid)));
    }
    try (PrintWriter out = new PrintWriter(new FileWriter(a[4]))) {
      out.println("sim,name,shape,terrain,sigma,hidden,vx,x_first,x_last,x_end,y_end,seconds");
      int done = 0;
      for (Future<String> f : futures) {
        out.println(f.get());
        out.flush();
        if (++done % 50 == 0) System.err.printf("%d/%d%n", done, futures.size());
      }
    }
    pool.shutdown();
  }

  /** pairs GENOMES.txt PAIRS.txt SIGMA OUT.csv: each line of PAIRS is "name terrain". */
  static void pairs(String[] a) throws Exception {
    Map<String, G> byName = new HashMap<>();
    for (G g : readGenomes(a[1])) byName.put(g.name, g);
    List<String[]> ps = new ArrayList<>();
    try (BufferedReader r = new BufferedReader(new FileReader(a[2]))) {
      String line;
      while ((line = r.readLine()) != null) if (!line.isBlank()) ps.add(line.trim().split("\\s+"));
    }
    boolean sigmoid = !System.getenv().getOrDefault("HIDDEN", "sigmoid").equals("tanh");
    ExecutorService pool = Executors.newFixedThreadPool(threads());
    List<Future<String>> futures = new ArrayList<>();
    for (String[] p : ps) futures.add(pool.submit(() -> episodeRow(byName.get(p[0]), p[1], a[3], sigmoid)));
    try (PrintWriter out = new PrintWriter(new FileWriter(a[4]))) {
      out.println("sim,name,shape,terrain,sigma,hidden,vx,x_first,x_last,x_end,y_end,seconds");
      for (Future<String> f : futures) {
        out.println(f.get());
        out.flush();
      }
    }
    pool.shutdown();
  }

  /**
   * GAP=1 (dump mode): a last column, the robot's lowest block corner's height above the
   * terrain's line at that corner's x (somite's min_height diagnostic, per control step): below
   * 0, a corner inside the ground or an end wall.
   */
  static double lowestGap(Grid<? extends SensingVoxel> voxels, List<int[]> order, double[][] ground) {
    double gap = Double.POSITIVE_INFINITY;
    for (int[] xy : order) {
      for (Body b : voxels.get(xy[0], xy[1]).getVertexBodies()) {
        Rectangle r = (Rectangle) b.getFixture(0).getShape();
        for (Vector2 v : r.getVertices()) {
          Vector2 w = b.getTransform().getTransformed(v);
          gap = Math.min(gap, w.y - groundAt(ground, w.x));
        }
      }
    }
    return gap;
  }

  static double groundAt(double[][] ground, double x) {
    double[] xs = ground[0], ys = ground[1];
    if (x <= xs[0]) return ys[0];
    for (int i = 1; i < xs.length; i++) {
      if (x <= xs[i]) return ys[i - 1] + (ys[i] - ys[i - 1]) * (x - xs[i - 1]) / (xs[i] - xs[i - 1]);
    }
    return ys[ys.length - 1];
  }

  static void dump(String[] a) throws Exception {
    G g = readGenomes(a[1]).stream().filter(x -> x.name.equals(a[2])).findFirst().orElseThrow();
    boolean sigmoid = !System.getenv().getOrDefault("HIDDEN", "sigmoid").equals("tanh");
    Soc c = new Soc(g, sigmoid);
    Robot<SensingVoxel> robot = buildRobot(g.shape, a[4], c);
    c.record = true;
    c.robot = robot;
    c.order = voxelOrder(robot.getVoxels());
    if ("1".equals(System.getenv("GAP"))) c.ground = terrain(a[3]);
    Locomotion loc = new Locomotion(30d, terrain(a[3]), new Settings());
    Outcome o = loc.apply(robot, null);
    try (PrintWriter out = new PrintWriter(new FileWriter(a[5]))) {
      for (double[] row : c.rows) {
        StringBuilder sb = new StringBuilder();
        for (int i = 0; i < row.length; i++) {
          if (i > 0) sb.append(',');
          sb.append(i == 0 ? String.valueOf((int) row[i]) : String.format(Locale.ROOT, "%.10g", row[i]));
        }
        out.println(sb);
      }
    }
    System.out.printf(Locale.ROOT, "vx=%.6f steps=%d%n", o.subOutcome(5d, 30d).getVelocity(), c.rows.size());
  }

  static double parsePhase(String s) {
    switch (s) {
      case "mpi2": return -Math.PI / 2d;
      case "mpi4": return -Math.PI / 4d;
      default: return Double.parseDouble(s);
    }
  }

  /** PhaseSin plus, for control steps 301..1800 (t in [5, 30)), every voxel's area ratio. */
  static class RecSin implements Controller<ControllableVoxel> {
    final PhaseSin inner;
    final List<int[]> order;
    final double[][] ar, act;
    int step;

    RecSin(PhaseSin inner, List<int[]> order) {
      this.inner = inner;
      this.order = order;
      ar = new double[order.size()][1500];
      act = new double[order.size()][1500];
    }

    @Override
    public void control(double t, Grid<? extends ControllableVoxel> voxels) {
      inner.control(t, voxels);
      step++;
      if (step >= 301 && step <= 1800) {
        for (int v = 0; v < order.size(); v++) {
          ControllableVoxel vox = voxels.get(order.get(v)[0], order.get(v)[1]);
          ar[v][step - 301] = vox.getAreaRatio();
          act[v][step - 301] = vox.getLastAppliedForce();
        }
      }
    }

    @Override
    public void reset() {
      inner.reset();
      step = 0;
    }
  }

  /** Mean over voxels of: first-harmonic amplitude at f (steps k = 301..1800, t = k/60),
   *  (p95 - p5) / 2, standard deviation, and the mean area ratio. */
  static double[] areaStats(double[][] ar, double[][] act, double f) {
    double h1 = 0, hr = 0, sd = 0, mean = 0, lagRe = 0, lagIm = 0;
    int nv = ar.length;
    for (int v = 0; v < nv; v++) {
      double[] s = ar[v];
      {
        // phase lag of the area's first harmonic behind -actuation (contraction shrinks the area)
        double are = 0, aim = 0, cre = 0, cim = 0, m0 = 0;
        for (double d : s) m0 += d;
        m0 /= s.length;
        for (int i = 0; i < s.length; i++) {
          double t = (i + 301) / 60d, w = 2 * Math.PI * f * t;
          are += (s[i] - m0) * Math.cos(w); aim -= (s[i] - m0) * Math.sin(w);
          cre += -act[v][i] * Math.cos(w); cim -= -act[v][i] * Math.sin(w);
        }
        double na = Math.hypot(cre, cim);
        if (na > 1e-9 * s.length && Math.hypot(are, aim) > 0) {
          // (area / (-act)) = |.| e^{-i lag}; accumulate unit vectors of the ratio
          double rre = (are * cre + aim * cim), rim = (aim * cre - are * cim);
          double nr = Math.hypot(rre, rim);
          lagRe += rre / nr; lagIm += rim / nr;
        }
      }
      int n = s.length;
      double m = 0;
      for (double d : s) m += d;
      m /= n;
      double re = 0, im = 0, var = 0;
      for (int i = 0; i < n; i++) {
        double t = (i + 301) / 60d;
        re += (s[i] - m) * Math.cos(2 * Math.PI * f * t);
        im += (s[i] - m) * Math.sin(2 * Math.PI * f * t);
        var += (s[i] - m) * (s[i] - m);
      }
      double factor = Math.abs(f - 30d) < 1e-9 ? 1d : 2d; // Nyquist: the component is (-1)^k
      h1 += factor * Math.hypot(re, im) / n;
      double[] c = s.clone();
      Arrays.sort(c);
      hr += (c[(int) Math.round(0.95 * (n - 1))] - c[(int) Math.round(0.05 * (n - 1))]) / 2d;
      sd += Math.sqrt(var / n);
      mean += m;
    }
    double lag = -Math.toDegrees(Math.atan2(lagIm, lagRe));
    return new double[]{h1 / nv, hr / nv, sd / nv, mean / nv, lag};
  }

  @SuppressWarnings("unchecked")
  static String sweepRow(String shape, String terrainName, String fs, String ps) {
    double f = Double.parseDouble(fs);
    double phi = parsePhase(ps);
    Grid<Boolean> s = RobotUtils.buildShape(shape);
    Grid<? extends SensingVoxel> body = RobotUtils.buildSensorizingFunction("spinedTouchSighted-f-f-0.01").apply(s);
    Grid<Double> phaseGrid = Grid.create(body.getW(), body.getH(), (x, y) -> phi * x);
    RecSin c = new RecSin(new PhaseSin(f, 1d, phaseGrid), voxelOrder(body));
    Robot<ControllableVoxel> robot = new Robot<>(c, (Grid<ControllableVoxel>) (Grid<?>) body);
    Locomotion loc = new Locomotion(30d, terrain(terrainName), new Settings());
    Outcome o = loc.apply(robot, null);
    Outcome sub = o.subOutcome(5d, 30d);
    double[] st = areaStats(c.ar, c.act, f);
    return String.format(Locale.ROOT, "java,%s,%s,%s,%s,%.6f,%.9f,%.6f,%.6f,%.6f,%.6f,%.2f",
        shape, terrainName, fs, ps, phi, sub.getVelocity(), st[0], st[1], st[2], st[3], st[4]);
  }

  static void sweep(String[] a) throws Exception {
    ExecutorService pool = Executors.newFixedThreadPool(threads());
    List<Future<String>> futures = new ArrayList<>();
    for (String shape : a[1].split(",")) for (String t : a[2].split(","))
      for (String f : a[3].split(",")) for (String p : a[4].split(",")) {
        futures.add(pool.submit(() -> sweepRow(shape, t, f, p)));
      }
    try (PrintWriter out = new PrintWriter(new FileWriter(a[5]))) {
      out.println("sim,shape,terrain,freq,phase_name,phase,vx,ar_h1,ar_halfrange,ar_sd,ar_mean,lag_deg");
      for (Future<String> fu : futures) {
        String row = fu.get();
        out.println(row);
        out.flush();
        System.err.println(row);
      }
    }
    pool.shutdown();
  }

  static void layout(String[] a) {
    Grid<Boolean> s = RobotUtils.buildShape(a[1]);
    Grid<? extends SensingVoxel> body = sensorize(s, "0.01");
    for (int[] xy : voxelOrder(body)) {
      StringBuilder sb = new StringBuilder();
      sb.append(xy[0]).append(',').append(xy[1]).append(':');
      for (Sensor sensor : body.get(xy[0], xy[1]).getSensors()) {
        sb.append(' ').append(sensor.toString().replaceAll("\\s+", "")).append('[').append(sensor.domains().length).append(']');
      }
      System.out.println(sb);
    }
  }

  public static void main(String[] a) throws Exception {
    switch (a[0]) {
      case "genomes": genomes(a); break;
      case "dump": dump(a); break;
      case "pairs": pairs(a); break;
      case "sweep": sweep(a); break;
      case "layout": layout(a); break;
      default: throw new IllegalArgumentException(a[0]);
    }
  }
}
