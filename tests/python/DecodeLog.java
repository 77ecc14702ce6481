// An independent decoder of mfot's messages (tests/python/test_mfot_spy.py): LCM's own Java
// library reads a log and the classes `scripts/mfot-spy` builds with lcm-gen -j decode its events.
import lcm.logging.Log;

public class DecodeLog {
  public static void main(String[] args) throws Exception {
    Log log = new Log(args[0], "r");
    while (true) {
      Log.Event event;
      try {
        event = log.readNext();
      } catch (java.io.EOFException end) {
        break;
      }
      switch (event.channel) {
        case "MFOT_HEARTBEAT": {
          mfot.heartbeat_t m = new mfot.heartbeat_t(event.data);
          System.out.println("heartbeat worker " + m.worker_id + " host " + m.host + " object " + m.object_id);
          break;
        }
        case "MFOT_POSES": {
          mfot.poses_t m = new mfot.poses_t(event.data);
          System.out.println("poses frame " + m.frame_seq + " objects " + m.num_objects + " first id " + m.objects[0].id);
          break;
        }
        case "MFOT_ESTIMATE": {
          mfot.tracker_estimate_t m = new mfot.tracker_estimate_t(event.data);
          System.out.println("estimate frame " + m.frame_seq + " object " + m.object_id + " particles " + m.num_particles);
          break;
        }
        default:
          System.out.println("unexpected channel " + event.channel);
      }
    }
  }
}
