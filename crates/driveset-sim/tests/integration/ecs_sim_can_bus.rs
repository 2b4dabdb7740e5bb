//! The simulated ECS on the simulated CAN bus ([`SimCanBus`], virtual
//! time): the codec's SDO client against the drive's SDO server through a
//! [`FrameLink`], exact frames and exact virtual instants (request wire
//! time + the drive's fixed 1 ms reaction + response wire time).

use crate::ecs_support as support;

use std::time::Duration;

use driveset_link::{Clock, FrameLink, Instant, VirtualClock};
use driveset_proto::can::timing::{Stuffing, frame_bits, frame_time_ns};
use driveset_proto::can::{
    AbortCode, CanFrame, ClientEvent, CodeNumber, Completed, NodeId, SdoAbort, SdoClient, Subindex,
};
use driveset_schema::canonical::{CodeKey, RawValue};
use driveset_sim::can_bus::SimCanBus;
use driveset_sim::drive::FrameDrive;
use support::test_drive;

fn wire(f: &CanFrame) -> Duration {
    Duration::from_nanos(frame_time_ns(frame_bits(f, Stuffing::Exact).unwrap(), 500_000).unwrap())
}

/// Runs one client transfer to its end over the bus.
fn transfer(
    bus: &mut SimCanBus,
    node: NodeId,
    client: &mut SdoClient,
    first: driveset_proto::can::SdoRequest,
) -> ClientEvent {
    let mut q = first;
    loop {
        bus.send(&q.to_can(node)).expect("send");
        let deadline = bus.clock().now() + Duration::from_secs(1);
        let f = bus
            .recv(deadline)
            .expect("recv")
            .expect("an answer within 1 s");
        assert_eq!(f.id, node.response_cob_id());
        match client.on_frame_data(f.payload()) {
            ClientEvent::Send(next) => q = next,
            other => return other,
        }
    }
}

#[test]
fn sdo_client_reads_and_writes_the_ecs_over_sim_can_bus() {
    let clock = VirtualClock::new();
    let drives: Vec<Box<dyn FrameDrive>> = vec![Box::new(test_drive(1)), Box::new(test_drive(2))];
    let mut bus = SimCanBus::new(&clock, 500_000, drives).expect("bus");
    let node = NodeId::new(1).unwrap();
    let c5001 = CodeNumber::new(5001).unwrap();

    // One expedited read, timed exactly in virtual time.
    let start = clock.now();
    let mut client = SdoClient::new();
    let q = client.start_read(c5001.index(), Subindex(0)).unwrap();
    let ev = transfer(&mut bus, node, &mut client, q);
    assert_eq!(
        ev,
        ClientEvent::Done(Completed::Read {
            index: c5001.index(),
            subindex: Subindex(0),
            data: 30_000_000i32.to_le_bytes().to_vec(),
        })
    );
    let req = q.to_can(node);
    let resp = CanFrame::new(0x581, &[0x43, 0x76, 0x4C, 0x00, 0x80, 0xC3, 0xC9, 0x01]).unwrap();
    assert_eq!(
        clock.now(),
        start + wire(&req) + Duration::from_millis(1) + wire(&resp)
    );

    // A 6-byte value goes segmented (0x21) and is refused after its last
    // segment: 0x06070010. Then an expedited write to C5002.
    let c5004 = CodeNumber::new(5004).unwrap();
    let q = client
        .start_write(c5004.index(), Subindex(0), &[0; 6])
        .unwrap();
    assert_eq!(
        transfer(&mut bus, node, &mut client, q),
        ClientEvent::Aborted(SdoAbort::new(
            c5004.index(),
            Subindex(0),
            AbortCode::LENGTH_MISMATCH
        ))
    );
    let c5002 = CodeNumber::new(5002).unwrap();
    let q = client
        .start_write(c5002.index(), Subindex(0), &12_345_678i32.to_le_bytes())
        .unwrap();
    assert!(matches!(
        transfer(&mut bus, node, &mut client, q),
        ClientEvent::Done(Completed::Written { .. })
    ));

    // Only node 1 changed.
    let drives = bus.into_drives();
    assert_eq!(
        drives[0].state().values[&CodeKey::new(5002)],
        RawValue::Int(12_345_678)
    );
    assert_eq!(
        drives[1].state().values[&CodeKey::new(5002)],
        RawValue::Int(0)
    );
    assert!(clock.now() > Instant::ZERO);
}
