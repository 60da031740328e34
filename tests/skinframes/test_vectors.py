"""The codecs against hand-built frames (../shared/reference/vectors.md): both directions."""

from __future__ import annotations

import ipaddress

import pytest
from data.vectors import VECTORS

from skinframes import decode_frame, ethercat, powerlink
from skinframes.ethercat import Command, Datagram, EcatFrame
from skinframes.ethernet import EthernetFrame
from skinframes.powerlink import (
    ASnd,
    IdentResponse,
    NmtCommand,
    NmtCommandId,
    NmtState,
    PReq,
    PRes,
    RequestedService,
    Sdo,
    SdoCommand,
    SoA,
    SoC,
    StatusResponse,
)

VECTOR_ECAT_SRC = bytes.fromhex("020000000001")  # vectors.md uses this master MAC

# Each model is written from the field values that frames.md / vectors.md state, not from our decoder.
MODELS: dict[int, EthernetFrame] = {
    1: powerlink.frame(
        SoC(net_time_s=1_700_000_000, net_time_ns=123_456_789, relative_time_us=1000)
    ),
    2: powerlink.frame(PReq(1, bytes(range(8)))),
    3: powerlink.frame(PRes(1, bytes(range(192)))),
    4: powerlink.frame(SoA(RequestedService.IDENT_REQUEST, 1)),
    5: powerlink.frame(
        ASnd(
            IdentResponse(
                nmt_status=NmtState.OPERATIONAL,
                feature_flags=0x45,
                mtu=300,
                poll_in_size=192,
                poll_out_size=192,
                response_time=25_000,
                device_type=401,
                vendor_id=0x0100006C,
                product_code=0x1234,
                revision_number=1,
                serial_number=42,
                ip_address=ipaddress.IPv4Address("192.168.100.1"),
                subnet_mask=ipaddress.IPv4Address("255.255.255.0"),
                default_gateway=ipaddress.IPv4Address("192.168.100.254"),
                host_name=b"cn1".ljust(32, b"\0"),
            ),
            src=1,
        )
    ),
    6: powerlink.frame(ASnd(StatusResponse(short=True), src=1)),  # a 60-byte frame
    7: powerlink.frame(ASnd(NmtCommand(NmtCommandId.START_NODE), dest=1)),
    8: powerlink.frame(ASnd(Sdo(0, 2, 1, 2, SdoCommand(1, 2, bytes.fromhex("00100000"))), dest=1)),
    9: ethercat.frame(
        EcatFrame(
            tuple(
                Datagram.logical(Command.LRD, 0x10000 + 4 * i, bytes(4), idx=0x10 + i, wkc=1)
                for i in range(3)
            )
        ),
        src=VECTOR_ECAT_SRC,
    ),
    10: ethercat.frame(
        EcatFrame((Datagram(Command.BRD, 0, 0x0130, bytes(2), idx=0x20, wkc=3),)),
        src=VECTOR_ECAT_SRC,
    ),
}


@pytest.mark.parametrize("n", sorted(VECTORS))
def test_encode_matches_hand_built_bytes(n: int) -> None:
    assert MODELS[n].to_bytes() == VECTORS[n][1]


@pytest.mark.parametrize("n", sorted(VECTORS))
def test_strict_decode_gives_the_model(n: int) -> None:
    frame = decode_frame(VECTORS[n][1], strict=True)
    assert frame == MODELS[n]
    # vector 6 is a 60-byte StatusResponse: legal, but shorter than an openPOWERLINK MN accepts
    assert [f.code for f in frame.findings] == (["epl.sres.short"] if n == 6 else [])


def test_ident_response_ip_is_little_endian_on_the_wire() -> None:
    # frames.md: 192.168.100.1 travels as 01 64 a8 c0
    assert bytes.fromhex("0164a8c0") in VECTORS[5][1]
    frame = decode_frame(VECTORS[5][1])
    assert isinstance(frame.payload, ASnd)
    assert isinstance(frame.payload.service, IdentResponse)
    assert str(frame.payload.service.ip_address) == "192.168.100.1"
    assert frame.payload.service.host_name.rstrip(b"\0") == b"cn1"
